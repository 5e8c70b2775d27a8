"""The safety supervisor with a sonar ring back from down: beside and behind the robot only
the ring looks, and a ring that may miss a body on a few scans (a scenario's
``dropout_probability``, a real ring's misses) has not seen the room on its first scan back.
It counts as up only once every sonar has scanned for ``sonar_miss_ms``; until then the
robot drives only where the camera looks."""

from __future__ import annotations

import math

import pytest
from oimi.pipeline.act.limits import Velocity
from oimi.pipeline.act.safety import SafetySupervisor
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.events import SafetyZone
from oimi.pipeline.messages import Sonar
from supervision import LIMITS, TICK_MS, echo, room, supervise

SCAN_MS = 200
BACK_MS = 1000


def beside_a_child(missed: int, miss_ms: int | None, phase_ms: int) -> tuple[float, float]:
    """A child stands 0.35 m (surfaces) to the robot's left, outside the camera's view
    (2.2 rad; it frames every 100 ms and reports nobody). Of a ring of two sonars scanning
    every 200 ms, ``left`` is offline until 1000 ms, then scans from ``phase_ms`` after,
    missing the child on its first ``missed`` scans and reporting their echo on each after
    (the supervisor told ``sonar_miss_ms``). The robot asks for 0.5 m/s straight at them
    for 3 s: the nearest their surfaces came (the dead reckoning taken for the motion) and
    how far the robot went, m."""
    config = SafetyConfig(robot_radius_m=0.3, camera_fov_rad=2.2, sonar_miss_ms=miss_ms)
    supervisor = SafetySupervisor(config, LIMITS, tick_ms=TICK_MS)
    centre_m = 0.35 + 0.3 + 0.25
    nearest, reported, heard_ms = math.inf, None, None
    for tick in range(150):
        now_ms = tick * TICK_MS
        x, y, heading = supervisor.reckoned_pose
        apart = math.hypot(x, centre_m - y)
        nearest = min(nearest, apart - 0.3 - 0.25)
        back = now_ms >= BACK_MS + phase_ms
        scanned = {"right": now_ms - now_ms % SCAN_MS}
        if back:
            scanned["left"] = now_ms - (now_ms - phase_ms) % SCAN_MS
            scans = (scanned["left"] - BACK_MS - phase_ms) // SCAN_MS
            if scans >= missed and scanned["left"] == now_ms:
                bearing = math.atan2(centre_m - y, -x) - heading
                reported, heard_ms = echo(apart, bearing, at_ms=now_ms), now_ms
        world_map = room()
        world_map.sonars += [Sonar(id="left", isonline=back), Sonar(id="right", isonline=True)]
        heard = {("Camera", "front"): now_ms, ("Sonar", "left"): now_ms}
        heard[("Sonar", "right")] = now_ms
        if reported is not None:
            world_map.obstacles.append(reported)
            heard[("Obstacle", reported.id)] = heard_ms
        supervise(
            Velocity(0.0, 0.5, 0.0),
            world_map,
            now_ms=now_ms,
            heard=heard,
            scanned=scanned,
            framed={"front": now_ms - now_ms % 100},
            supervisor=supervisor,
        )
    return nearest, supervisor.reckoned_pose[1]


@pytest.mark.parametrize("phase_ms", [0, 60, 140])
def test_a_ring_back_that_may_miss_a_child_counts_once_it_has_scanned_for_its_misses(
    phase_ms: int,
) -> None:
    """The ring back misses the child on its first three scans. Taken for a ring that sees
    every body on every scan, it let the robot drive at them from its first scan back:
    into their stop zone before the fourth reported them. Told the ring may miss a body
    for 600 ms, the supervisor keeps the robot to the camera's view until every sonar has
    scanned that long: it drives once the child's echo is in, and stops short."""
    nearest, went = beside_a_child(3, None, phase_ms)
    assert nearest < 0.1 and went > 0.1
    nearest, went = beside_a_child(3, 600, phase_ms)
    assert nearest >= 0.1 and went > 0.05


def test_a_ring_back_holds_the_robot_to_the_view_until_it_has_scanned_for_its_misses() -> None:
    """Both sonars scanning from 0 ms and ``sonar_miss_ms`` 400: a drive sideways (outside
    the view) is held as blind until both have scanned for 400 ms, then let through."""
    supervisor = SafetySupervisor(
        SafetyConfig(robot_radius_m=0.3, camera_fov_rad=2.2, sonar_miss_ms=400),
        LIMITS,
        tick_ms=TICK_MS,
    )
    world_map = room()
    world_map.sonars += [Sonar(id="left", isonline=True), Sonar(id="right", isonline=True)]
    zones = {}
    for now_ms in range(0, 600, TICK_MS):
        scan_ms = now_ms - now_ms % SCAN_MS
        verdict, _ = supervise(
            Velocity(0.0, 0.2, 0.0),
            world_map,
            now_ms=now_ms,
            scanned={"left": scan_ms, "right": scan_ms},
            supervisor=supervisor,
        )
        zones[now_ms] = verdict.zone
    assert zones[0] is zones[380] is SafetyZone.BLIND
    assert zones[400] is None and zones[580] is None
