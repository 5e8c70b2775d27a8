"""What the safety property (``test_safety_property.py``) reads of a session's record
besides the world's true state: how far a recorded velocity may be from the true one,
which humans the sensors reported when, and how far the supervisor's margin covers a walk."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import NamedTuple

from oimi.pipeline.events import Topic
from oimi.pipeline.sink import MemorySink
from oimi.scenarios.simulation.bodies import STATE_DECIMALS

TICK_MS = 20
"""The scenarios' tick."""


class Ran(NamedTuple):
    """A trial's session: what it recorded, and how far a human may walk from where a
    report placed them that the supervisor's margin covers: ``human_speed_mps`` for
    ``max_data_age_ms`` (a camera's reading), or for as long as the ring may keep an echo
    it no longer reports (``echo_hold_ms``, no less: a ring's)."""

    memory: MemorySink
    walk_covered_m: float
    echo_walk_m: float


def least_closing(vx: float, vy: float, ux: float, uy: float) -> float:
    """The least closing speed along (ux, uy) of a velocity that ``/world/state`` records as
    (vx, vy): it cuts each speed towards zero to ``STATE_DECIMALS``, so a true speed lies
    between the recorded one and one step further from zero (either side of a zero)."""
    step = 10.0**-STATE_DECIMALS
    least = 0.0
    for v, u in ((vx, ux), (vy, uy)):
        far = (v + math.copysign(step, v), v) if v else (-step, step)
        least += min(end * u for end in far)
    return least


def reports(memory: MemorySink, names: Sequence[str]) -> dict[int, list[tuple[str, int, bool]]]:
    """By tick, the humans a sensor reported in it, each with the tick its reading was
    taken (a frozen sensor repeats an old one) and whether the ring's echo reported them;
    ``names``: the humans in the scenario's order (the ring names the N-th one's echo
    ``echo-N``, or ``echo-N.sK`` for a beam's; the room has no furniture)."""
    found: dict[int, list[tuple[str, int, bool]]] = {}
    for update in memory.on(Topic.SENSOR_UPDATES):
        for change in update.updates:  # type: ignore[attr-defined]
            kind, _, ident = change.objectid.partition("/")
            if change.attributename != "poses" or kind not in ("Human", "Obstacle"):
                continue
            if kind == "Obstacle":
                ident = names[int(ident.removeprefix("echo-").partition(".")[0])]
            taken = json.loads(change.jsonmsg)["positionchangetime"] // TICK_MS
            found.setdefault(update.tick, []).append((ident, taken, kind == "Obstacle"))
    return found
