"""Greeting: turn to the nearest child, approach slowly to about 1 m, greet with light and sound.

Scripts are open loop, so the search and the approach are bounded loops
unrolled into numbered steps: each step checks a condition with a jump block
and either moves on or does one small turn or step. A step is taken only while
the camera keeps seeing someone (a stale pose would walk the robot into the child);
otherwise the step waits. When the child is never found (or never reached), the
script ends in ``no_child_found``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Final

from oimi.pipeline.messages import RuleAction, Script
from oimi.pipeline.operator.generator import (
    BaseGenerator,
    Colour,
    OptionKind,
    OptionSpec,
    OptionValue,
)
from oimi.pipeline.operator.generators.build import (
    ScriptBuilder,
    alfa_messages,
    audio,
    led,
    move,
    omega_messages,
    safety_rules,
)
from oimi.pipeline.think.rulecodes import RuleCode

TURN_RADPS: Final = 0.6
"""Speed of one search turn, rad/s."""
STEP_MS: Final = 500
"""Duration of one turn or one step of the approach, ms."""
DIM: Final[Colour] = (0.1, 0.1, 0.3)
"""Colour shown while searching and approaching."""

REACH_M: Final = 4.0
"""With ``steps = auto``: the farthest child (centre to centre, m) the approach can reach."""

BLIND_STEPS: Final = 20
"""With ``steps = auto``: extra steps for waiting while the camera does not see the child."""

NO_HUMAN_IN_FRONT: Final = "! {E: no_human_in_front ()}"
SEEN_LATELY: Final = "{CLASS #Human L ?child B: seen_within (500)} ! {TRUE}"
"""Some human's pose was refreshed in the last 500 ms (the camera runs at 10 Hz)."""


def auto_steps(*, distance_m: float, speed_mps: float) -> tuple[int, int]:
    """``(turns, steps)`` for ``steps = auto``: turns enough for a full circle, steps enough
    to come from ``REACH_M`` to ``distance_m`` at ``speed_mps`` and to wait ``BLIND_STEPS``."""
    turns = math.ceil(2 * math.pi / (TURN_RADPS * STEP_MS / 1000))
    steps = math.ceil((REACH_M - distance_m) / (speed_mps * STEP_MS / 1000)) + BLIND_STEPS
    return turns, steps


def near_child(distance_m: float) -> str:
    """The condition "the nearest child is within ``distance_m``"."""
    return f"{{CLASS #Human L ?child}} ! {{E: near (?child, {distance_m:g})}}"


class GreetingGenerator(BaseGenerator):
    """Find the child, approach, greet."""

    name = "greeting"
    title = "Greeting"
    description = (
        "The robot turns towards the nearest child, comes slowly closer until about "
        "1 m, and says hello with light and sound."
    )
    options = (
        OptionSpec(
            name="distance_m",
            kind=OptionKind.NUMBER,
            default="1.0",
            min=0.5,
            max=1.5,
            help="how close to come, metres (centre to centre; the approach overshoots by "
            "up to 0.1 m, and child_too_close softens a moving block under 0.8 m)",
        ),
        OptionSpec(
            name="speed_mps",
            kind=OptionKind.NUMBER,
            default="0.15",
            min=0.05,
            max=0.3,
            help="approach speed, m/s",
        ),
        OptionSpec(
            name="steps",
            kind=OptionKind.CHOICE,
            default="auto",
            choices=("auto",),
            min=1,
            max=40,
            integer=True,
            help="most turns (and most steps) before giving up; auto: a full circle of "
            "turns and enough steps to reach a child 4 m away",
        ),
        OptionSpec(
            name="colour", kind=OptionKind.COLOUR, default="yellow", help="the greeting's light"
        ),
        OptionSpec(
            name="sound",
            kind=OptionKind.TEXT,
            default="sounds/hello.wav",
            help="the greeting's sound",
        ),
    )

    def build(self, values: Mapping[str, OptionValue]) -> Script:
        distance = float(values["distance_m"])  # type: ignore[arg-type]
        speed = float(values["speed_mps"])  # type: ignore[arg-type]
        if values["steps"] == "auto":
            turns, steps = auto_steps(distance_m=distance, speed_mps=speed)
        else:
            turns = steps = int(values["steps"])  # type: ignore[arg-type]
        colour: Colour = values["colour"]  # type: ignore[assignment]
        sound = str(values["sound"])

        b = ScriptBuilder(self.name)
        b.rules(
            alfa=alfa_messages(
                *safety_rules(RuleAction.A), (RuleCode.TOUCH_REWARD, "touch_reward", RuleAction.A)
            ),
            omega=omega_messages(
                *safety_rules(RuleAction.R), (RuleCode.TOUCH_REWARD, "touch_reward", RuleAction.R)
            ),
        )
        dim = led(DIM, duration_ms=STEP_MS)

        b.goal("turn_to_child")
        for i in range(turns):
            b.jump(NO_HUMAN_IN_FRONT, true=f"turn{i}", false="approach0", label=f"look{i}")
            b.instruction(
                moves=(move(v_theta_radps=TURN_RADPS, duration_ms=STEP_MS),),
                leds=(dim,),
                label=f"turn{i}",
            )
        b.jump("! {TRUE}", true="give_up")

        b.goal("approach_child")
        for i in range(steps):
            b.jump(near_child(distance), true="greet", label=f"approach{i}")
            following = f"approach{i + 1}" if i + 1 < steps else "last_check"
            b.jump(NO_HUMAN_IN_FRONT, true=f"realign{i}", false=f"check{i}")
            b.instruction(
                moves=(move(v_theta_radps=TURN_RADPS, duration_ms=STEP_MS // 2),),
                leds=(dim,),
                label=f"realign{i}",
            )
            b.jump("! {TRUE}", true=following)
            # A pose not refreshed lately (camera offline or frozen) is stale: wait, not step.
            b.jump(SEEN_LATELY, true=f"step{i}", false=f"blind{i}", label=f"check{i}")
            b.instruction(leds=(dim,), label=f"blind{i}")
            b.jump("! {TRUE}", true=following)
            b.instruction(
                moves=(move(v_x_mps=speed, duration_ms=STEP_MS),), leds=(dim,), label=f"step{i}"
            )
        b.jump(near_child(distance), true="greet", false="give_up", label="last_check")

        b.goal("greet_child")
        b.instruction(
            moves=(
                move(v_theta_radps=0.5, duration_ms=400),
                move(v_theta_radps=-0.5, duration_ms=800),
                move(v_theta_radps=0.5, duration_ms=400),
            ),
            leds=(
                led(colour, duration_ms=800),
                led(colour, duration_ms=200, on=False),
                led(colour, duration_ms=800),
            ),
            sounds=(audio(sound, duration_ms=1600),),
            label="greet",
        )
        b.terminus()

        b.goal("no_child_found")
        b.instruction(leds=(led(DIM, duration_ms=1000),), label="give_up")
        b.terminus()
        return b.build()
