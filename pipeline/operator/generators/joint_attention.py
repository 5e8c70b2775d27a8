"""Joint attention game: look at the target object, show a colour, wait for the child, reward.

Each round is a goal: the robot turns (in bounded steps) until the target
object (an ``Object`` with ``istarget``) is in front, shows the round's colour,
then waits a bounded number of tries for the child to come in front of it and
near; then it rewards with light and sound. A round whose child never comes
jumps to the next round; after the last round the script ends.
"""

from __future__ import annotations

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

TURN_RADPS: Final = 0.5
"""Speed of one search turn towards the target, rad/s."""
TURN_MS: Final = 400
"""Duration of one search turn, ms."""
SEARCH_TURNS: Final = 16
"""Most search turns per round (16 x 0.2 rad is a full circle)."""
FRONT_RAD: Final = 0.35
"""Half-width of "in front", rad."""

TARGET_IN_FRONT: Final = (
    f"{{CLASS #Object L ?toy ?THIS>&istarget OP= 1, B: infront ({FRONT_RAD})}} ! {{TRUE}}"
)


def child_engaged(near_m: float) -> str:
    """The condition "a child is in front of the robot and within ``near_m``"."""
    return f"{{CLASS #Human L ?child B: infront ({FRONT_RAD})}} ! {{E: near (?child, {near_m:g})}}"


class JointAttentionGenerator(BaseGenerator):
    """Several rounds of look, show, wait, reward."""

    name = "joint_attention"
    title = "Joint attention game"
    description = (
        "The robot turns to the target toy and lights up; when the child comes close "
        "in front of it, the robot rewards them with light and sound. Several rounds."
    )
    options = (
        OptionSpec(
            name="rounds",
            kind=OptionKind.NUMBER,
            default="3",
            min=1,
            max=8,
            integer=True,
            help="how many rounds (three goals each)",
        ),
        OptionSpec(
            name="colours",
            kind=OptionKind.COLOUR,
            default="green,blue,purple",
            multiple=True,
            help="the colour shown in each round, cycled",
        ),
        OptionSpec(
            name="tries",
            kind=OptionKind.NUMBER,
            default="5",
            min=1,
            max=20,
            integer=True,
            help="how many checks for the child before moving on",
        ),
        OptionSpec(
            name="wait_ms",
            kind=OptionKind.NUMBER,
            default="1500",
            min=200,
            max=10000,
            integer=True,
            help="time between two checks, ms",
        ),
        OptionSpec(
            name="near_m",
            kind=OptionKind.NUMBER,
            default="1.0",
            min=0.4,
            max=2.0,
            help="how near the child must come, metres",
        ),
        OptionSpec(
            name="reward_sound",
            kind=OptionKind.TEXT,
            default="sounds/well_done.wav",
            help="the reward's sound",
        ),
    )

    def build(self, values: Mapping[str, OptionValue]) -> Script:
        rounds = int(values["rounds"])  # type: ignore[arg-type]
        colours: tuple[Colour, ...] = values["colours"]  # type: ignore[assignment]
        tries = int(values["tries"])  # type: ignore[arg-type]
        wait_ms = int(values["wait_ms"])  # type: ignore[arg-type]
        near_m = float(values["near_m"])  # type: ignore[arg-type]
        sound = str(values["reward_sound"])

        b = ScriptBuilder(self.name)
        b.rules(
            alfa=alfa_messages(
                *safety_rules(RuleAction.A),
                (RuleCode.ATTENTION_LOST, "attention_lost", RuleAction.A),
            ),
            omega=omega_messages(
                *safety_rules(RuleAction.R),
                (RuleCode.ATTENTION_LOST, "attention_lost", RuleAction.R),
            ),
        )
        for r in range(rounds):
            colour = colours[r % len(colours)]
            after = f"r{r + 1}" if r + 1 < rounds else "end"
            b.goal(f"round{r + 1}_look_at_target")
            for i in range(SEARCH_TURNS):
                b.jump(TARGET_IN_FRONT, true=f"r{r}_show", label=f"r{r}" if i == 0 else "")
                b.instruction(
                    moves=(move(v_theta_radps=TURN_RADPS, duration_ms=TURN_MS),),
                    leds=(led(colour, duration_ms=TURN_MS, on=False),),
                )
            b.action()  # found, or searched a full circle: show the colour either way
            b.instruction(leds=(led(colour, duration_ms=1000),), label=f"r{r}_show")
            b.goal(f"round{r + 1}_child_attends")
            for _ in range(tries):
                b.jump(child_engaged(near_m), true=f"r{r}_reward")
                b.instruction(leds=(led(colour, duration_ms=wait_ms),))
            b.jump("! {TRUE}", true=after)
            b.goal(f"round{r + 1}_reward")
            b.instruction(
                moves=(
                    move(v_theta_radps=0.8, duration_ms=500),
                    move(v_theta_radps=-0.8, duration_ms=500),
                ),
                leds=(
                    led((1.0, 1.0, 1.0), duration_ms=300),
                    led(colour, duration_ms=300),
                    led((1.0, 1.0, 1.0), duration_ms=400),
                ),
                sounds=(audio(sound, duration_ms=1000),),
                label=f"r{r}_reward",
            )
        b.goal("game_over")
        b.instruction(leds=(led((0.0, 0.0, 0.0), duration_ms=200, on=False),), label="end")
        b.terminus()
        return b.build()
