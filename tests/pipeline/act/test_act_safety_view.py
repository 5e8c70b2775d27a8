"""The safety supervisor with a sonar down: the robot drives only where the camera looks,
and "where it looks" counts a child's body, not their centre. The camera reports a child
whose centre is in its view; one centred just outside it is a disc that reaches into it,
and a robot driving along the view's edge drives into them (the review of e563091, M2: a
child 2 degrees outside the 2.2 rad view, never reported, driven into at the slow speed)."""

from __future__ import annotations

import math

import pytest
from oimi.pipeline.act.limits import Velocity
from oimi.pipeline.act.safety import SafetySupervisor
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.act.separation import sighted_range_m
from oimi.pipeline.events import SafetyZone
from oimi.pipeline.messages import Sonar
from supervision import FRONT, LIMITS, TICK_MS, room, seen, supervise

STOP_REACH_M = 0.3 + 0.25 + 0.02 + 0.1
"""Centre to centre, the stop zone's edge on a fresh reading: both radii, the sensing error
and the stop distance."""
SLOW_REACH_M = 0.3 + 0.25 + 0.02 + 0.5
"""The same for the slow zone's edge."""


def ring_down(config: SafetyConfig, request: Velocity) -> tuple[float, float]:
    """What the supervisor lets through of ``request`` in an empty room (nobody in the
    camera's view) with the ring offline."""
    world_map = room()
    world_map.sonars.append(Sonar(id="ring", isonline=False))
    verdict, _ = supervise(request, world_map, config=config)
    return verdict.velocity.v_x, verdict.velocity.v_y


def passes_at(v_x: float, v_y: float, x: float, y: float) -> float:
    """How near the robot's centre, driving straight on at (v_x, v_y), comes to (x, y)."""
    speed = math.hypot(v_x, v_y)
    along = (x * v_x + y * v_y) / speed
    if along <= 0.0:
        return math.hypot(x, y)
    return abs(x * v_y - y * v_x) / speed


def test_a_drive_along_the_view_keeps_off_a_child_just_outside_it() -> None:
    """The review's session (M2): a child standing 1.13 m away, 2 degrees outside the
    2.2 rad view, never reported (the ring's one scan missed them, then it fell silent);
    the pad asks for their bearing. Projected onto the view's edge, the drive passed their
    centre at 4 cm, into them at 0.2 m/s; onto the narrowed edge, at 0.75 m."""
    child = (0.481, 1.024)
    assert abs(math.atan2(child[1], child[0])) > 1.1  # outside the view
    v_x, v_y = ring_down(FRONT, Velocity(0.426, 0.905, 0.0))
    assert math.hypot(v_x, v_y) == pytest.approx(0.2 * math.cos(1.131 - 0.42), abs=0.01)
    assert passes_at(v_x, v_y, *child) >= STOP_REACH_M


@pytest.mark.parametrize("fov_rad", [2.2, 3.0, 5.0])
def test_with_the_ring_down_no_drive_reaches_a_body_outside_the_view_beyond_the_slow_zone(
    fov_rad,
) -> None:
    """Whatever is asked (every 5 degrees round), the drive let through passes every
    point just outside either edge of the view, from the slow zone's edge out to 5 m, no
    nearer than the stop zone's edge: a child centred there, standing, is never driven
    into the stop zone, though the camera never reports them."""
    config = SafetyConfig(robot_radius_m=0.3, camera_fov_rad=fov_rad)
    outside = [
        (d * math.cos(side * (fov_rad / 2 + 1e-6)), d * math.sin(side * (fov_rad / 2 + 1e-6)))
        for side in (-1, 1)
        for d in (SLOW_REACH_M + 0.05 * k for k in range(80))
    ]
    moved = 0
    for degrees in range(0, 360, 5):
        angle = math.radians(degrees)
        v_x, v_y = ring_down(config, Velocity(0.5 * math.cos(angle), 0.5 * math.sin(angle), 0.0))
        if v_x == v_y == 0.0:
            continue
        moved += 1
        assert min(passes_at(v_x, v_y, x, y) for x, y in outside) >= STOP_REACH_M - 1e-9
    assert moved > 10


def test_a_narrow_camera_with_the_ring_down_lets_no_linear_motion_through() -> None:
    """A 1 rad camera (the supervisor's assumption without a scenario): even straight
    ahead, a child 30 degrees off it and 1.3 m away, centred outside the view, would be
    driven into. With the ring down the robot may only turn (blind)."""
    assert passes_at(1.0, 0.0, 1.3 * math.cos(0.52), 1.3 * math.sin(0.52)) < STOP_REACH_M
    world_map = room()
    world_map.sonars.append(Sonar(id="ring", isonline=False))
    verdict, _ = supervise(Velocity(0.5, 0.0, 0.4), world_map)
    assert verdict.velocity == (0.0, 0.0, 0.4) and verdict.zone is SafetyZone.BLIND
    world_map.sonars[0].isonline = True  # the ring back: it sees beside the robot again
    assert supervise(Velocity(0.5, 0.0, 0.4), world_map)[0].velocity == (0.5, 0.0, 0.4)


def toward_a_child_beyond_the_range(
    range_m: float,
    frame_ms: int,
    *,
    down: bool = True,
    walk_mps: float = 0.0,
    phase_ms: int = 0,
    missed: int = 0,
    miss_ms: int | None = None,
    start_m: float | None = None,
) -> tuple[float, float, float]:
    """A child ``start_m`` ahead (centre; by default 1.4 m, or 3 m or 1 m beyond the range
    when walking at the robot at ``walk_mps``); the
    camera (2.2 rad) frames every ``frame_ms`` (from ``phase_ms``) and reports them only
    while their centre is within ``range_m``, and not on the first ``missed`` frames that
    could (``miss_ms``: the supervisor's ``camera_miss_ms``); of a ring of two sonars one is offline
    (``down``: nothing sees beside the robot; the other keeps the speed from the blind cap).
    The robot asks for 0.5 m/s straight at them for 3 s (until a walking child reaches its
    stop zone): the nearest their surfaces came (the dead reckoning taken for the motion),
    how far the robot went, m, and its speed in the tick the child reached its stop zone
    (0.0: it was at rest, or they never did), m/s."""
    config = SafetyConfig(
        robot_radius_m=0.3, camera_fov_rad=2.2, camera_range_m=range_m, camera_miss_ms=miss_ms
    )
    supervisor = SafetySupervisor(config, LIMITS, tick_ms=TICK_MS)
    if start_m is None:  # (walking: in from beyond the range)
        start_m = max(3.0, range_m + 1.0) if walk_mps else 1.4
    nearest, humans, framed, went = math.inf, [], -10_000, 0.0
    for tick in range(150):
        now_ms = tick * TICK_MS
        apart = start_m - walk_mps * now_ms / 1000 - supervisor.reckoned_pose[0]
        nearest = min(nearest, apart - 0.3 - 0.25)
        if nearest <= 0.1 and walk_mps:  # a walking child in the stop zone: how it drove
            return nearest, supervisor.reckoned_pose[0], went / (TICK_MS / 1000)
        if (now_ms - phase_ms) % frame_ms == 0:
            framed, humans = now_ms, [seen(apart, at_ms=now_ms)] if apart <= range_m else []
            if humans and missed:
                missed, humans = missed - 1, []
        world_map = room(*humans)
        world_map.sonars += [Sonar(id="left", isonline=True), Sonar(id="right", isonline=not down)]
        request = Velocity(0.5, 0.0, 0.0)
        before = supervisor.reckoned_pose[0]
        supervise(
            request, world_map, now_ms=now_ms, framed={"front": framed}, supervisor=supervisor
        )
        went = supervisor.reckoned_pose[0] - before
    return nearest, supervisor.reckoned_pose[0], 0.0


def test_with_the_ring_down_a_camera_too_short_to_see_a_child_in_time_lets_no_drive() -> None:
    """A 0.7 m camera framing at 10 Hz: the child comes into range 0.7 m away, is reported
    up to a frame later, and the base, at 0.5 m/s, goes 0.135 m more as it brakes: the robot
    drove into the child (0 m surface to surface), never having seen them in its view.
    Below ``separation.sighted_range_m`` the robot may only turn while the ring is down;
    with the ring up it drives (the ring sees what the camera cannot)."""
    nearest, went, _ = toward_a_child_beyond_the_range(0.7, 100)
    assert nearest >= 0.1 and went == 0.0
    assert toward_a_child_beyond_the_range(0.7, 100, down=False)[1] > 0.5


def test_with_the_ring_down_a_camera_too_short_to_see_a_walking_child_in_time_lets_no_drive():
    """A 1.6 m camera sees a child standing ahead in time (1.055 m would do), but not one
    walking at the robot at 1 m/s: taken for standing, the robot still drove at 0.34 m/s
    when the child reached its stop zone (at 0.5 m/s with a 1.3 m camera). The least range
    counts their walk: the robot may only turn, and is at rest when they come."""
    for phase_ms in range(0, 500, 20):
        nearest, went, speed = toward_a_child_beyond_the_range(
            1.6, 500, walk_mps=1.0, phase_ms=phase_ms
        )
        assert went == 0.0 and speed == 0.0 and nearest <= 0.1


def test_with_the_ring_down_a_camera_reaching_the_least_range_sees_the_child_in_time() -> None:
    """The least range's derivation, at its worst: frames only every ``max_frame_age_ms``
    (500 ms; a camera slower counts as offline), at every phase of the child's coming into
    range. The robot drives, and is at rest before a child walking at it at
    ``human_speed_mps`` reaches its stop zone; it stops short of a child standing."""
    least_m = sighted_range_m(STOP_REACH_M, 0.5, 1.0, 0.5, TICK_MS / 1000, 1.0)
    assert least_m == pytest.approx(0.67 + 0.25 + 0.135 + 1.02)
    for phase_ms in range(0, 500, 20):
        nearest, went, speed = toward_a_child_beyond_the_range(
            least_m + 1e-6, 500, walk_mps=1.0, phase_ms=phase_ms
        )
        assert went > 0.3 and speed == 0.0, phase_ms
    nearest, went, _ = toward_a_child_beyond_the_range(least_m + 1e-6, 500)
    assert nearest >= 0.1 and went > 0.3


def test_with_the_ring_down_a_camera_that_may_miss_a_child_counts_its_misses() -> None:
    """A camera at the least range that misses the walking child on its first two frames
    that could report them (a person tracker's dropouts): taken for one that never misses,
    the robot still drove when the child reached its stop zone. Told so (``camera_miss_ms``:
    two frames), the supervisor's least range grows by what both close in meanwhile: the
    same camera leaves the robot only turning, and one reaching the longer range sees the
    child in time, at every phase."""
    least_m = sighted_range_m(STOP_REACH_M, 0.5, 1.0, 0.5, TICK_MS / 1000, 1.0)
    speeds = [
        toward_a_child_beyond_the_range(
            least_m + 1e-6, 500, walk_mps=1.0, phase_ms=phase_ms, missed=2
        )[2]
        for phase_ms in range(0, 500, 20)
    ]
    assert max(speeds) > 0.3  # (the robot at speed when the child reached its stop zone)
    for phase_ms in range(0, 500, 20):
        told = toward_a_child_beyond_the_range(
            least_m + 1e-6, 500, walk_mps=1.0, phase_ms=phase_ms, missed=2, miss_ms=1000
        )
        assert told[1] == 0.0 and told[2] == 0.0, phase_ms
    longer_m = sighted_range_m(STOP_REACH_M, 0.5, 1.0, 1.5, TICK_MS / 1000, 1.0)
    assert longer_m == pytest.approx(least_m + 0.5 * 1.0 + 1.0 * 1.0)
    for phase_ms in range(0, 500, 20):
        _, went, speed = toward_a_child_beyond_the_range(
            longer_m + 1e-6, 500, walk_mps=1.0, phase_ms=phase_ms, missed=2, miss_ms=1000
        )
        assert went > 0.3 and speed == 0.0, phase_ms


def test_with_the_ring_down_a_camera_back_drives_once_it_has_looked_for_its_misses() -> None:
    """The ring down and the camera offline until its first frame: the robot only turns.
    A child stands 0.4 m ahead (surfaces), whom the camera, back, misses on its first two
    frames (500 ms apart). Driving from the first frame on, the robot went into their stop
    zone before the third reported them. Told the camera may miss a child for 1000 ms, it
    drives in the view only once the camera has framed that long: it stops short. (A 4 m
    camera: beyond the least range that those misses need, 3.575 m.)"""
    for phase_ms in (0, 120, 260, 480):
        nearest, went, _ = toward_a_child_beyond_the_range(
            4.0, 500, phase_ms=phase_ms, missed=2, start_m=0.95
        )
        assert nearest < 0.1 and went > 0.1, phase_ms
        nearest, went, _ = toward_a_child_beyond_the_range(
            4.0, 500, phase_ms=phase_ms, missed=2, start_m=0.95, miss_ms=1000
        )
        assert nearest >= 0.1 and went < 0.1, phase_ms


@pytest.mark.parametrize("frozen", [False, True])
def test_with_the_ring_down_a_camera_that_does_not_look_lets_no_drive(frozen: bool) -> None:
    """One of two sonars offline and the camera offline (or its latest frame 10 s old):
    the view the robot is kept to while the ring is down is the camera's, and nothing
    looks there; a child ahead in the down sonar's sector is reported by no sensor. The
    robot may only turn (it drove at the blind cap, 0.2 m/s)."""
    world_map = room(camera=frozen)
    world_map.sonars += [Sonar(id="left", isonline=True), Sonar(id="right", isonline=False)]
    framed = {"front": -10_000} if frozen else None
    verdict, _ = supervise(Velocity(0.5, 0.0, 0.4), world_map, config=FRONT, framed=framed)
    assert verdict.velocity == (0.0, 0.0, 0.4) and verdict.zone is SafetyZone.BLIND
