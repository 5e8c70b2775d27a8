"""The safety supervisor, a ring whose beams merge and the camera's range
(``camera_range_m``): an echo is taken for a tracked child only where the camera's frame
would have reported any body that made it, its centre within the camera's range (the
coverage rule, ``pipeline/act/echoes.py``). A child beyond the range is never reported: their
echo, in the tracked child's gate and in a beam the camera sees whole, was dropped (review
MEDIUM-1: the robot closed on them)."""

from __future__ import annotations

import math

import msgspec
import pytest
from oimi.pipeline.act.limits import Velocity
from oimi.pipeline.act.safety import SafetySupervisor
from oimi.pipeline.act.safety_config import ASSUMED, SafetyConfig
from oimi.pipeline.events import SafetyZone
from oimi.pipeline.messages import Sonar, WorldMap
from supervision import LIMITS, TICK_MS, echo, room, seen, supervise

BEAM = math.tau / 12
"""12 sonars of 30 degrees, the first straight ahead."""
WIDE = SafetyConfig(robot_radius_m=0.3, camera_fov_rad=2.6, sonar_beam_rad=BEAM)
"""A wide camera (2.6 rad): it sees the whole beam 30 degrees right at 0.62 m (its half
view 1.3 rad, more than the beam's axis 0.52, half a beam 0.26 and a body's 0.45)."""
BODY_M = 0.25 + 0.02
"""A body's radius and the sensing error (how far a body's centre lies beyond its surface)."""


def room_with_two_children(*, merged_at_ms: int = 0, now_ms: int = 0) -> WorldMap:
    """The camera tracks H 0.72 m away, 6 degrees left: the sonar ahead hears their surface
    (0.47 m). U, a second child, stands 30 degrees right, their centre 0.87 m away: the
    sonar there hears U's surface, 0.62 m, on its axis; H's centre lies 0.26 m from that
    echo's arc (H's body outside its beam), in H's gate. The camera reports U only within
    its range: at 0.8 m, never."""
    world_map = room(seen(0.72, math.radians(6), at_ms=now_ms))
    world_map.sonars.append(Sonar(id="ring", isonline=True))
    own = msgspec.structs.replace(echo(0.47, 0.0, at_ms=now_ms), id="echo-1")
    world_map.obstacles += [echo(0.62, -BEAM, at_ms=merged_at_ms), own]
    return world_map


def closing_on_the_arc(velocity: Velocity) -> float:
    """The fastest the robot closes on a point of U's echo's arc (30 degrees right, half a
    beam either side), m/s."""
    return max(
        velocity.v_x * math.cos(bearing) + velocity.v_y * math.sin(bearing)
        for bearing in (-BEAM * 1.5, -BEAM, -BEAM / 2)
    )


def test_a_child_beyond_the_cameras_range_merged_into_a_tracked_childs_echo_is_kept() -> None:
    """Drive at U (0.5 m/s): taken for H (slow zone), their echo let the robot close on
    every point of its arc at up to 0.12 m/s though it lies in the stop zone (its distance,
    taken as a centre's). U's centre may lie 0.62 + 0.27 m away, beyond the camera's 0.8 m:
    the camera's frame does not say U is not there, the echo is kept and stops the robot
    (it backs away). H's own echo (0.47 + 0.27 m, within range) is still H."""
    config = msgspec.structs.replace(WIDE, camera_range_m=0.8)
    supervisor = SafetySupervisor(config, LIMITS, tick_ms=TICK_MS)
    drive = Velocity(0.5 * math.cos(-BEAM), 0.5 * math.sin(-BEAM), 0.0)
    verdict, _ = supervise(drive, room_with_two_children(), supervisor=supervisor)
    assert verdict.human == "Obstacle/echo-0" and verdict.zone is SafetyZone.STOP
    assert closing_on_the_arc(verdict.velocity) <= 1e-9


@pytest.mark.parametrize(
    ("range_m", "kept"),
    [
        (0.62 + BODY_M - 0.01, True),
        (0.62 + BODY_M + 0.01, False),  # the camera would have reported U: the echo is H
        (5.0, False),  # the scenarios' camera
    ],
)
def test_an_echo_is_a_tracked_childs_only_when_its_body_was_within_the_cameras_range(
    range_m: float, kept: bool
) -> None:
    """The bound is the echo's range and a body (0.89 m): within the camera's range the
    coverage rule still drops the echo, and the tracked child decides (slow zone)."""
    config = msgspec.structs.replace(WIDE, camera_range_m=range_m)
    supervisor = SafetySupervisor(config, LIMITS, tick_ms=TICK_MS)
    verdict, _ = supervise(Velocity(0.5, 0.0, 0.0), room_with_two_children(), supervisor=supervisor)
    assert verdict.human == ("Obstacle/echo-0" if kept else "child"), range_m


@pytest.mark.parametrize(("range_m", "kept"), [(0.62 + BODY_M + 0.09, True), (1.0, False)])
def test_a_walk_between_the_echo_and_the_frame_counts_against_the_range(
    range_m: float, kept: bool
) -> None:
    """The echo 100 ms older than the camera's frame: U may have walked 0.1 m (at 1 m/s)
    farther by then, up to 0.99 m away when the camera looked. (A wider camera, 3 rad: the
    walk widens the angle the camera must see too.)"""
    config = msgspec.structs.replace(WIDE, camera_fov_rad=3.0, camera_range_m=range_m)
    supervisor = SafetySupervisor(config, LIMITS, tick_ms=TICK_MS)
    world_map = room_with_two_children(merged_at_ms=0, now_ms=100)
    verdict, _ = supervise(Velocity(0.5, 0.0, 0.0), world_map, now_ms=100, supervisor=supervisor)
    assert verdict.human == ("Obstacle/echo-0" if kept else "child"), range_m


def test_without_a_scenario_the_camera_is_taken_to_report_people_within_3_m() -> None:
    """A pipeline without a scenario (and a real robot whose scenario states no camera
    range, ``oimi bridge``) assumes a short-ranged person tracker: 3 m."""
    assert ASSUMED["camera_range_m"] == 3.0
    assert SafetyConfig().filled().camera_range_m == 3.0


def driven(supervisor: SafetySupervisor, ticks: int) -> dict[int, tuple[float, float, float]]:
    """Drive straight ahead at 0.5 m/s (nothing in view: nothing limits) for ``ticks``; the
    reckoned pose after each, by time (ms)."""
    poses = {}
    for tick in range(ticks):
        now_ms = tick * TICK_MS
        world_map = room()
        world_map.sonars.append(Sonar(id="ring", isonline=True))
        supervise(Velocity(0.5, 0.0, 0.0), world_map, now_ms=now_ms, supervisor=supervisor)
        poses[now_ms + TICK_MS] = supervisor.reckoned_pose
    return poses


@pytest.mark.parametrize(("beyond_m", "kept"), [(-0.02, True), (0.02, False)])
def test_the_robots_move_between_the_frame_and_the_echo_counts_against_the_range(
    beyond_m: float, kept: bool
) -> None:
    """The camera's frame placed H 200 ms before the ring's echo of U, the robot driving
    ahead meanwhile (0.1 m): U's body may lie that much farther from where the camera
    looked than from where the ring heard it. (No walk: ``human_speed_mps`` 0; a camera
    that sees 3.4 rad: the move widens the angle it must see too.) Kept with the camera's
    range 2 cm short of the echo's range, a body and the move; dropped 2 cm beyond."""
    poses = driven(SafetySupervisor(WIDE, LIMITS, tick_ms=TICK_MS), 40)  # the same drive
    now_ms, frame_ms = 40 * TICK_MS, 40 * TICK_MS - 200
    moved_m = poses[now_ms][0] - poses[frame_ms][0]
    assert 0.099 < moved_m < 0.101
    x, y = 0.62 * math.cos(-BEAM) - moved_m, 0.62 * math.sin(-BEAM)  # U's echo, now
    reach_m = math.hypot(x, y) + BODY_M + moved_m
    config = msgspec.structs.replace(
        WIDE, camera_fov_rad=3.4, human_speed_mps=0.0, camera_range_m=reach_m + beyond_m
    )
    supervisor = SafetySupervisor(config, LIMITS, tick_ms=TICK_MS)
    driven(supervisor, 40)
    world_map = room(seen(0.72, math.radians(6), at_ms=frame_ms))
    world_map.sonars.append(Sonar(id="ring", isonline=True))
    world_map.obstacles.append(echo(math.hypot(x, y), math.atan2(y, x), at_ms=now_ms))
    verdict, _ = supervise(Velocity(0.5, 0.0, 0.0), world_map, now_ms=now_ms, supervisor=supervisor)
    assert verdict.human == ("Obstacle/echo-0" if kept else "child"), beyond_m
