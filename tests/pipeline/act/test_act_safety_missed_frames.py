"""The coverage rule with a camera that may miss a child (``EchoSorter._covers``,
``camera_miss_ms``): an echo of a merging ring is taken for the child the camera tracks
only where the camera saw all the beam that made it. A camera that may miss a child on
its frames for ``camera_miss_ms`` tells little by one frame's silence: a second child in
that beam, missed by it, would be merged into the tracked child's echo and forgotten. So
the camera must have framed, and seen all of the beam, on every frame for that long
before: the robot's path and turns then count, as does a walk that long. A 12-sonar ring
(30 degree beams) that reports centres; a child the camera tracks 0.1 m beyond the echo's
range (1.5 m), 0.3 rad off its heading, both readings taken at 1000 ms."""

from __future__ import annotations

import math

import pytest
from oimi.pipeline.act.echoes import Anchor, EchoSorter
from oimi.pipeline.act.limits import Velocity
from oimi.pipeline.act.reckoning import DeadReckoning
from oimi.pipeline.act.safety_config import SafetyConfig
from supervision import LIMITS, TICK_MS, echo

RHO_M = 1.5
BEARING = 0.3
FRAME_MS = 1000


def kept(*, miss_ms: int, spin: float, framing_since_ms: float = 0.0) -> bool:
    """Whether the echo is kept as a body of its own (not taken for the tracked child),
    the robot having spun at ``spin`` rad/s (asked) until the frame, the camera framing
    since ``framing_since_ms`` and its frames missing a child for ``miss_ms``."""
    config = SafetyConfig(
        robot_radius_m=0.3,
        sonar_beam_rad=math.tau / 12,
        camera_fov_rad=2.2,
        camera_range_m=5.0,
        camera_miss_ms=miss_ms,
    ).filled()
    reckoning = DeadReckoning(LIMITS, tick_ms=TICK_MS, kept_ms=4000, error=0.05, push_mps=1.0)
    for now_ms in range(0, FRAME_MS + TICK_MS, TICK_MS):
        reckoning.mark(now_ms)
        if now_ms < FRAME_MS:
            reckoning.advance(Velocity(0.0, 0.0, spin))
    x, y, heading = reckoning.pose

    def placed(rho: float) -> Anchor:
        at = heading + BEARING
        return Anchor(
            FRAME_MS,
            FRAME_MS,
            x + rho * math.cos(at),
            y + rho * math.sin(at),
            reckoning.placed(FRAME_MS),
        )

    heard, frame = placed(RHO_M), placed(RHO_M + 0.1)
    sorter = EchoSorter(config, reckoning)
    anchors = {"Obstacle/echo-0": heard, "child": frame}
    reading = echo(RHO_M, BEARING, at_ms=FRAME_MS)
    left = sorter.unexplained(
        [("Obstacle/echo-0", reading, 0)], [frame], anchors, False, framing_since_ms
    )
    return bool(left)


def test_a_camera_that_misses_no_one_covers_the_beam_by_its_one_frame() -> None:
    """The beam's half (15 degrees), the body's angle at 1.5 m (10.4) and the bearing
    (17.2) lie within the 2.2 rad camera's half view (63): taken for the child, whatever
    the robot did before the frame."""
    assert not kept(miss_ms=0, spin=0.0)
    assert not kept(miss_ms=0, spin=1.0)


def test_a_camera_that_may_miss_a_child_covers_the_beam_only_if_it_looked_there_all_along():
    """With ``camera_miss_ms`` 400: standing, the camera looked at the beam on every frame
    for 400 ms (a walk of 0.4 m at 1.5 m: 15.5 degrees more): taken for the child. Having
    spun at 1 rad/s into the frame, the camera looked elsewhere on the frames before, and a
    second child in the beam may have been missed by the one frame that saw it: kept (one
    frame's silence alone took it for the child). A camera framing only since 800 ms
    (back from offline): kept, and so where the moves from 600 ms are no longer kept."""
    assert not kept(miss_ms=400, spin=0.0)
    assert kept(miss_ms=400, spin=1.0)
    assert kept(miss_ms=400, spin=0.0, framing_since_ms=800.0)
    assert not kept(miss_ms=400, spin=0.0, framing_since_ms=600.0)


@pytest.mark.parametrize(("start_ms", "turned"), [(600, 0.4), (900, 0.1)])
def test_the_reckoning_says_how_far_the_robot_turned_off_its_heading_since(start_ms, turned):
    """Spinning at 1 rad/s (reached within a tick or two: the angular acceleration), the
    heading at 1000 ms lies about that far from each heading since ``start_ms``."""
    reckoning = DeadReckoning(LIMITS, tick_ms=TICK_MS, kept_ms=4000, error=0.05, push_mps=1.0)
    for now_ms in range(0, FRAME_MS + TICK_MS, TICK_MS):
        reckoning.mark(now_ms)
        if now_ms < FRAME_MS:
            reckoning.advance(Velocity(0.0, 0.0, 1.0))
    swept = reckoning.swept(start_ms, FRAME_MS)
    assert swept is not None and swept.distance_m == 0.0
    assert swept.heading_rad == pytest.approx(turned, abs=0.005)
    assert reckoning.swept(-100_000, FRAME_MS) is None  # (before the states kept)
