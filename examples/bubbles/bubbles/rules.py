"""The extension's rule: a popped bubble is rewarded, counted and told to the generator."""

from __future__ import annotations

from typing import Final

from oimi.pipeline.messages import AudioOut, InstructionBlock, Led, WorldMap
from oimi.pipeline.think.conditions import Evaluation
from oimi.pipeline.think.rules import Effect, Rule, RuleContext

from .functions import POPS

POP_REWARD: Final = 1000
"""Extension rule codes start at 1000 (0..999 are oimi's)."""
ENOUGH: Final = 3
"""After this many pops the generator is set back to quiescence (Get Ready)."""


class PopReward(Rule):
    """A touch pops a bubble: a sparkle and a pop, once per touch; the ``bubbles`` generator
    hears each pop, and is set quiescent after ``ENOUGH`` of them."""

    rulecode = POP_REWARD
    condition_text = "! {E: bubble_touch (600)}"
    sparkle = InstructionBlock(
        led=(Led(r=0.6, g=0.9, b=1.0, turnas=1, wait_t=0, duration=300),),
        audioout=(AudioOut(track_path="pop.wav", wait_t=0, duration=300),),
        flagged="pop",
    )

    def act(self, world_map: WorldMap, found: Evaluation, ctx: RuleContext) -> Effect:
        latest = str(world_map.robotstatus.touch[-1].startingtime)
        if world_map.variables.get("@bubble_popped_at") == latest:
            return Effect.UNCHANGED  # this touch was rewarded already
        world_map.variables["@bubble_popped_at"] = latest
        pops = int(world_map.variables.get(POPS, "0")) + 1
        world_map.variables[POPS] = str(pops)
        world_map.scriptinfo.block = self.sparkle
        world_map.scriptinfo.changed = True
        self.tell(ctx, "bubbles", f"popped {pops}")
        if pops == ENOUGH:
            self.quiesce(ctx, "bubbles")
        return Effect.CHANGED
