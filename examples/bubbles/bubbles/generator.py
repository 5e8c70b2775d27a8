"""The ``bubbles`` generator: bubbles blown near or far, depending on where the child is."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Final

from oimi.pipeline.messages import RuleAction, Script
from oimi.pipeline.operator.generator import BaseGenerator, OptionKind, OptionSpec, OptionValue
from oimi.pipeline.operator.generators.build import (
    ScriptBuilder,
    alfa_messages,
    audio,
    led,
    omega_messages,
)

from .rules import POP_REWARD

NEAR_M: Final = 1.5
"""A child closer than this gets small, quick bubbles; farther, big slow ones."""


class BubblesGenerator(BaseGenerator):
    """Blows ``rounds`` bubbles; looks at the map to see how far the child is, remembers
    how many scripts it made, and listens to ``PopReward``."""

    name = "bubbles"
    title = "Bubbles"
    description = "The robot blows bubbles for the child to chase and pop with a touch."
    options = (
        OptionSpec(
            name="rounds",
            kind=OptionKind.NUMBER,
            default="4",
            min=1,
            max=12,
            integer=True,
            help="how many bubbles",
        ),
    )

    def distance_m(self) -> float | None:
        """The nearest child's distance in the map this generator last saw (None: no one)."""
        if self.view is None or not self.view.world_map.humans:
            return None
        return min(h.positionrho for h in self.view.world_map.humans)

    def build(self, values: Mapping[str, OptionValue]) -> Script:
        rounds = int(values["rounds"])  # type: ignore[arg-type]
        distance = self.distance_m()
        near = distance is not None and distance < NEAR_M
        self.state["scripts"] = int(self.state.get("scripts", 0)) + 1  # type: ignore[arg-type]
        self.state["near"] = near
        bubble_ms = 600 if near else 1500
        b = ScriptBuilder(self.name)
        b.rules(
            alfa=alfa_messages((POP_REWARD, "pop_reward", RuleAction.A)),
            omega=omega_messages((POP_REWARD, "pop_reward", RuleAction.R)),
        )
        b.goal("bubbles_near" if near else "bubbles_far")
        for _ in range(rounds):
            b.instruction(
                leds=(led((0.3, 0.7, 1.0), duration_ms=bubble_ms),),
                sounds=(audio("blow.wav", duration_ms=bubble_ms),),
            )
        b.jump("! {E: pops_at_least (2)}", false="more")
        b.goal("celebrate")
        b.instruction(leds=(led((1.0, 0.9, 0.2), duration_ms=1000),), label="party")
        b.terminus()
        b.goal("one_more")
        b.instruction(leds=(led((0.3, 0.7, 1.0), duration_ms=bubble_ms),), label="more")
        b.terminus()
        return b.build()
