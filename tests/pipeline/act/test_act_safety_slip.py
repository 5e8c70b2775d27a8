"""The coverage rule while a sonar is down (``EchoSorter._covers``, ``slipped``): the
reckoning may have slipped (a base pushed or blocked), so the robot's move between the
camera's frame and the ring's echo, reckoned, may be off by the slip counted since the
earlier of both readings; it counts against the camera's range and widens the angle the
camera must have seen, as the move does. A 12-sonar ring (30 degree beams) that reports
centres; a child the camera tracks 0.1 m beyond the echo's range, on its bearing; nobody
walks (``human_speed_mps`` 0); the robot stands, and a speed report says it went 0.3 m
(pushed) over the 200 ms between both readings: 0.315 m slip with the 5 % error."""

from __future__ import annotations

import math

import pytest
from oimi.pipeline.act.echoes import Anchor, EchoSorter
from oimi.pipeline.act.limits import Velocity
from oimi.pipeline.act.looking import SensorWatch
from oimi.pipeline.act.reckoning import DeadReckoning
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.messages import Obstacle, SpeedStatus
from supervision import LIMITS, TICK_MS, echo

RHO_M = 1.0
"""The echo's range."""
PUSHED = SpeedStatus(xspeed=1.5, yspeed=0.0, thetaspeed=0.0, duration=200, startingtime=0)
"""The base measured 0.3 m forward from 0 to 200 ms, where it was told to stand."""


def kept(*, echo_ms: int, frame_ms: int, bearing: float, fov_rad: float, range_m: float) -> bool:
    """Whether the echo (taken at ``echo_ms``, ``bearing`` rad off straight ahead) is kept
    as a body of its own, not taken for the child the camera placed at ``frame_ms``, at
    200 ms with a sonar down (the reckoning may have slipped)."""
    config = SafetyConfig(
        robot_radius_m=0.3,
        human_speed_mps=0.0,
        sonar_beam_rad=math.tau / 12,
        camera_fov_rad=fov_rad,
        camera_range_m=range_m,
    ).filled()
    reckoning = DeadReckoning(LIMITS, tick_ms=TICK_MS, kept_ms=2000, error=0.05, push_mps=1.0)
    for now_ms in range(0, 200 + TICK_MS, TICK_MS):
        reckoning.mark(now_ms)
        if now_ms < 200:
            reckoning.advance(Velocity())
    reckoning.measured([PUSHED], 200)
    assert reckoning.slip.distance_m == pytest.approx(0.315)

    def placed(at_ms: int, rho: float) -> Anchor:
        return Anchor(
            at_ms, at_ms, rho * math.cos(bearing), rho * math.sin(bearing), reckoning.placed(at_ms)
        )

    heard, frame = placed(echo_ms, RHO_M), placed(frame_ms, RHO_M + 0.1)
    reading: Obstacle = echo(RHO_M, bearing, at_ms=echo_ms)
    sorter = EchoSorter(config, reckoning, SensorWatch("Camera", 500, 0, TICK_MS))
    anchors = {"Obstacle/echo-0": heard, "child": frame}
    left = sorter.unexplained([("Obstacle/echo-0", reading, 0)], [frame], anchors, True)
    return bool(left)


@pytest.mark.parametrize(("range_m", "is_kept"), [(1.5, True), (1.7, False)])
def test_the_slip_since_an_earlier_frame_counts_against_the_cameras_range(range_m, is_kept):
    """The frame at 0 ms, the echo at 200 ms, the push between them: no slip is counted
    since the echo (the report came before it), 0.315 m since the frame. The body that
    made the echo may have stood 1 + 0.27 + 0.315 m from where the camera looked: beyond a
    1.5 m range, never reported (kept); within 1.7 m (taken for the child). Counted
    since the echo, a 1.5 m camera was taken to have seen it."""
    wide = {"bearing": 0.0, "fov_rad": 2.6}
    assert kept(echo_ms=200, frame_ms=0, range_m=range_m, **wide) is is_kept


@pytest.mark.parametrize(("degrees", "is_kept"), [(25, True), (10, False)])
def test_the_slip_widens_the_angle_the_camera_must_have_seen(degrees, is_kept):
    """The echo at 0 ms, the frame at 200 ms (the slip since the echo counted either way),
    a 2.2 rad camera reaching 5 m: the beam's half (15 degrees), the body's angle at 1 m
    (15.7) and the slip's (18.4: ``asin(0.315 / 1)``) must lie within its half view (63)
    with the echo's bearing. At 25 degrees off straight ahead the camera may not have seen
    all of it (kept); at 10, it did. Without the slip's angle, 25 degrees passed."""
    narrow = {"fov_rad": 2.2, "range_m": 5.0}
    assert kept(echo_ms=0, frame_ms=200, bearing=math.radians(degrees), **narrow) is is_kept
