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

import msgspec
import pytest
from oimi.pipeline.act.echoes import Anchor, EchoSorter
from oimi.pipeline.act.limits import Velocity
from oimi.pipeline.act.looking import SensorWatch
from oimi.pipeline.act.reckoning import DeadReckoning
from oimi.pipeline.act.safety import SafetySupervisor
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.messages import Camera, Sonar, SpeedStatus
from supervision import LIMITS, TICK_MS, echo, room, supervise
from test_act_safety_range import BEAM, WIDE, closing_on_the_arc, room_with_two_children

RHO_M = 1.5
BEARING = 0.3
FRAME_MS = 1000
FRONT = Camera(id="front", isonline=True)


def kept(
    *,
    miss_ms: int,
    spin: float,
    framing_since_ms: int = 0,
    slipped: bool = False,
    reported_ms: int | None = None,
) -> bool:
    """Whether the echo is kept as a body of its own (not taken for the tracked child),
    the robot having spun at ``spin`` rad/s (asked) until the frame, the camera framing
    since ``framing_since_ms`` and its frames missing a child for ``miss_ms``; with
    ``slipped`` (a sonar down) the reckoning's slip counts, the base having reported its
    speed (standing) from the start to ``reported_ms``, then nothing."""
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
        if now_ms == reported_ms:
            standing = SpeedStatus(
                xspeed=0.0, yspeed=0.0, thetaspeed=0.0, duration=now_ms, startingtime=0
            )
            reckoning.measured([standing], now_ms)
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
    cameras = SensorWatch("Camera", 10_000, miss_ms, TICK_MS)  # (its first frame then)
    cameras.working([FRONT], {("Camera", "front"): framing_since_ms}, framing_since_ms)
    sorter = EchoSorter(config, reckoning, cameras)
    anchors = {"Obstacle/echo-0": heard, "child": frame}
    reading = echo(RHO_M, BEARING, at_ms=FRAME_MS)
    left = sorter.unexplained([("Obstacle/echo-0", reading, 0)], [frame], anchors, slipped, [FRONT])
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
    assert kept(miss_ms=400, spin=0.0, framing_since_ms=800)
    assert not kept(miss_ms=400, spin=0.0, framing_since_ms=600)


def test_with_a_sonar_down_the_slip_counts_from_the_first_frame_that_must_have_looked():
    """A sonar down: the reckoning's slip counts. Reports up to the frame (the base stood):
    nothing slipped, the camera looked at the beam all along, taken for the child. Reports
    that stopped 400 ms before the frame, at the first of the frames that must all have
    looked: a person may have pushed the base 0.4 m meanwhile (1 m/s), so the camera may
    have looked that far off on those frames (33 degrees at 1.5 m, the walk's 0.4 m with
    it: beyond the 63 degree half view): kept. (Counted from the frame only, as before,
    nothing slipped: taken for the child.)"""
    assert not kept(miss_ms=400, spin=0.0, slipped=True, reported_ms=FRAME_MS)
    assert kept(miss_ms=400, spin=0.0, slipped=True, reported_ms=FRAME_MS - 400)


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


def towards_the_second_child(spin: float) -> tuple[str, float]:
    """The review's two children (``test_act_safety_range.room_with_two_children``: the
    camera tracks H, a second child U 30 degrees right, 0.62 m to their surface, whose
    echo lies in H's gate), a 3.4 rad camera reaching 5 m whose frames may miss a child
    for 200 ms, the robot having turned at ``spin`` rad/s (asked) for a second in an empty
    room, the ring and the camera working. The robot then asks for 0.5 m/s at U: the human
    whose separation bound it, and the fastest it closes on a point of U's echo's arc."""
    config = msgspec.structs.replace(
        WIDE, camera_fov_rad=3.4, camera_range_m=5.0, camera_miss_ms=200
    )
    supervisor = SafetySupervisor(config, LIMITS, tick_ms=TICK_MS)
    for now_ms in range(0, FRAME_MS, TICK_MS):
        world_map = room()
        world_map.sonars.append(Sonar(id="ring", isonline=True))
        supervise(Velocity(0.0, 0.0, spin), world_map, now_ms=now_ms, supervisor=supervisor)
    drive = Velocity(0.5 * math.cos(-BEAM), 0.5 * math.sin(-BEAM), 0.0)
    world_map = room_with_two_children(merged_at_ms=FRAME_MS, now_ms=FRAME_MS)
    verdict, _ = supervise(drive, world_map, now_ms=FRAME_MS, supervisor=supervisor)
    return verdict.human, closing_on_the_arc(verdict.velocity)


def test_a_second_child_the_camera_may_have_missed_is_kept_after_a_turn() -> None:
    """Standing, the camera looked at U's beam on every frame for 200 ms (their walk
    counted): a child there would have been reported, and the echo is H's (the slow zone
    binds). Having turned at 1 rad/s, its frames before looked elsewhere: U's echo is kept,
    in the stop zone, and the robot does not close on it. (Taken for H by the one frame, as
    before, the robot closed on U's arc at 0.12 m/s.)"""
    assert towards_the_second_child(0.0)[0] == "child"
    human, closing = towards_the_second_child(1.0)
    assert human == "Obstacle/echo-0" and closing <= 1e-9
