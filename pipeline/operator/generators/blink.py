"""The thesis's ``example_act`` (section 4.4): blink blue twice, then end.

The thesis loads an illustrative ``16,my_rule`` and removes ``kick_starter``
while the script runs, restoring it afterwards; here the loaded rule is the
safety rule ``CHILD_TOO_CLOSE`` from :mod:`pipeline.think.rulecodes`.
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
    led,
    omega_messages,
)
from oimi.pipeline.think.rulecodes import RuleCode

BLUE: Final[Colour] = (0.0, 0.0, 1.0)


class BlinkGenerator(BaseGenerator):
    """``example_act``: the LEDs blink ``times`` times in ``colour``."""

    name = "example_act"
    title = "Blink"
    description = "The robot's lights blink twice in blue, then the activity ends."
    options = (
        OptionSpec(
            name="colour", kind=OptionKind.COLOUR, default="blue", help="the blinking colour"
        ),
        OptionSpec(
            name="times",
            kind=OptionKind.NUMBER,
            default="2",
            min=1,
            max=10,
            integer=True,
            help="how many blinks",
        ),
        OptionSpec(
            name="blink_ms",
            kind=OptionKind.NUMBER,
            default="100",
            min=50,
            max=2000,
            integer=True,
            help="how long each blink lasts, ms",
        ),
    )

    def build(self, values: Mapping[str, OptionValue]) -> Script:
        colour: Colour = values["colour"]  # type: ignore[assignment]
        times = int(values["times"])  # type: ignore[arg-type]
        blink_ms = int(values["blink_ms"])  # type: ignore[arg-type]
        b = ScriptBuilder(self.name)
        b.rules(
            alfa=alfa_messages(
                (RuleCode.CHILD_TOO_CLOSE, "child_too_close", RuleAction.A),
                (RuleCode.KICK_STARTER, "kick_starter", RuleAction.R),
            ),
            omega=omega_messages(
                (RuleCode.KICK_STARTER, "kick_starter", RuleAction.C),
                (RuleCode.CHILD_TOO_CLOSE, "child_too_close", RuleAction.R),
            ),
        )
        b.goal("blinking_and_stop")
        # As in the thesis: LD("0, 0, 1, 1, 0, 100", "0, 0, 1, 1, 0, 100"); the actuator
        # turns the LEDs off after each item, which makes the blink.
        b.instruction(leds=tuple(led(colour, duration_ms=blink_ms) for _ in range(times)))
        return b.build()
