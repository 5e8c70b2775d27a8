"""What the safety property (``test_safety_property.py``) reads of a session's record
besides the world's true state: how far a recorded velocity may be from the true one,
which humans the sensors reported when, how far the supervisor's margin covers a walk, and
when the sonar ring was down."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import NamedTuple

from oimi.pipeline.act.safety_config import SafetyConfig
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
    safety: SafetyConfig
    """The supervisor's configuration, filled (what it assumed)."""


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


def ring_down(memory: MemorySink, safety: SafetyConfig, ticks: int) -> list[bool]:
    """For each tick below ``ticks``, whether the supervisor surely counted a sonar of the
    ring down then, by its own criteria read off the recorded ``/sensors/updates`` (which it
    consumes in the tick they come): the sonar's status last said it is offline, or was
    last heard more than ``max_status_age_ms`` ago, or its latest scan (``scantime``, taken
    no later than when it first came) is older than ``max_scan_age_ms``, or ahead by more
    than a tick, or never came, or the sonar's scans have not run without a break (each
    tick's latest within ``max_scan_age_ms``) for ``sonar_miss_ms`` (a ring back that may
    still miss a child: the view holds as while it is down). It counts a ring down in more
    cases (a status three
    quarters late, an old echo repeated: a frozen ring's, until its scan time ages too);
    those ticks are not claimed here (False: not surely down)."""
    safety = safety.filled()
    assert safety.max_status_age_ms is not None and safety.max_scan_age_ms is not None
    assert safety.sonar_miss_ms is not None
    by_tick: dict[int, list] = {}
    for update in memory.on(Topic.SENSOR_UPDATES):
        by_tick.setdefault(update.tick, []).extend(update.updates)  # type: ignore[attr-defined]
    status: dict[str, tuple[bool, int]] = {}  # sonar -> (said online, when heard, ms)
    scans: dict[str, tuple[int, int]] = {}  # sonar -> (its latest scantime, when noted, ms)
    since: dict[str, int] = {}  # sonar -> when its unbroken run of scans began, ms
    down = []
    for tick in range(ticks):
        now_ms = tick * TICK_MS
        for change in by_tick.get(tick, ()):
            kind, _, ident = change.objectid.partition("/")
            if kind != "Sonar":
                continue
            if change.attributename == "isonline":
                status[ident] = (change.jsonmsg == "s_true", now_ms)
            elif change.attributename == "scantime":
                stamp = int(change.jsonmsg)
                if ident not in scans or scans[ident][0] != stamp:
                    scans[ident] = (stamp, min(stamp, now_ms))
        for ident, (_, noted_ms) in scans.items():
            if now_ms - safety.max_scan_age_ms <= noted_ms <= now_ms + TICK_MS:
                since.setdefault(ident, noted_ms)
            else:
                since.pop(ident, None)
        down.append(
            any(
                not online
                or now_ms - heard_ms > safety.max_status_age_ms
                or ident not in since
                or now_ms - since[ident] < safety.sonar_miss_ms
                for ident, (online, heard_ms) in status.items()
            )
        )
    return down
