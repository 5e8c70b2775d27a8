"""The extension's condition functions (family E: true or false on the map)."""

from __future__ import annotations

from oimi.pipeline.think.functions import TIME, FunctionContext, evaluation

POPS = "@bubbles_popped"
"""The map variable where ``PopReward`` counts the popped bubbles."""


@evaluation("bubble_touch", reads=("robotstatus.touch", TIME))
def bubble_touch(ctx: FunctionContext, window_ms: float = 600) -> bool:
    """A touch of any kind started in the last ``window_ms``: a bubble popped.

    Example: ! {E: bubble_touch (600)}
    """
    since_ms = ctx.now_ms - window_ms
    return any(t.startingtime >= since_ms for t in ctx.world_map.robotstatus.touch)


@evaluation("pops_at_least", reads=("variables",))
def pops_at_least(ctx: FunctionContext, count: float) -> bool:
    """At least ``count`` bubbles were popped in this session.

    Example: ! {E: pops_at_least (2)}
    """
    return int(ctx.world_map.variables.get(POPS, "0")) >= count
