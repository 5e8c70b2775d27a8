"""The safety supervisor and a ring whose beams merge (``sonar_beam_rad`` > 0): an echo is
taken for a tracked child only where the camera saw all that the beam which made it may
hold (the coverage rule, ``pipeline/act/echoes.py``); anywhere else it is kept."""

from __future__ import annotations

import math

import msgspec
from oimi.pipeline.act.limits import Velocity
from oimi.pipeline.act.safety import SafetySupervisor
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.events import SafetyZone
from oimi.pipeline.messages import Sonar, WorldMap
from supervision import LIMITS, TICK_MS, centre_at, echo, room, seen, supervise

NARROW = SafetyConfig(robot_radius_m=0.3, camera_fov_rad=2.2, sonar_beam_rad=math.tau / 36)
"""36 sonars of 10 degrees, the scenarios' camera (2.2 rad). At 0.76 m (an echo 3 cm
nearer than a child 0.2 m away, surface to surface: the echo, kept, binds) a body's disc
subtends 0.36 rad: an echo (on its beam's axis) taken with the camera's frame is a tracked
child's within 1.1 - 0.09 - 0.36 = 0.65 rad of straight ahead (half a beam each side)."""


def ringed(*humans, echoes=(), now_ms: int = 0) -> WorldMap:
    world_map = room(*humans)
    world_map.sonars.append(Sonar(id="ring", isonline=True))
    world_map.obstacles += list(echoes)
    return world_map


def towards(bearing: float, speed: float = 0.5) -> Velocity:
    return Velocity(speed * math.cos(bearing), speed * math.sin(bearing), 0.0)


def narrow() -> SafetySupervisor:
    return SafetySupervisor(NARROW, LIMITS, tick_ms=TICK_MS)


def test_an_echo_in_a_beam_the_camera_sees_whole_is_the_tracked_child() -> None:
    """Ahead, the child's echo (3 cm nearer than the camera places them) is the child: the
    camera's reading decides (the slow zone's cap, not a stop)."""
    child = seen(centre_at(0.2), 0.2)
    own = echo(centre_at(0.2) - 0.03, 0.2)
    verdict, _ = supervise(towards(0.2), ringed(child, echoes=[own]), supervisor=narrow())
    assert verdict.human == "child" and verdict.zone is SafetyZone.SLOW


def test_an_echo_whose_beam_reaches_past_the_cameras_view_is_kept() -> None:
    """At 0.7 rad the beam that made the echo may reach past the camera's edge (1.1 rad):
    a child there, unseen, would be merged into the seen child's echo (``make soak
    SEED=35`` on a real ring). The echo is kept, 3 cm nearer than the child: it binds."""
    child = seen(centre_at(0.2), 0.7)
    merged = echo(centre_at(0.2) - 0.03, 0.7)
    verdict, _ = supervise(towards(0.7), ringed(child, echoes=[merged]), supervisor=narrow())
    assert verdict.human == "Obstacle/echo-0"
    wider = msgspec.structs.replace(NARROW, sonar_beam_rad=math.tau / 8)  # 45 degrees
    child = seen(centre_at(0.2), 0.4)  # even at 0.4 rad: half a beam's 0.39, a disc's 0.36
    own = echo(centre_at(0.2) - 0.03, 0.4)
    supervisor = SafetySupervisor(wider, LIMITS, tick_ms=TICK_MS)
    verdict, _ = supervise(towards(0.4), ringed(child, echoes=[own]), supervisor=supervisor)
    assert verdict.human == "Obstacle/echo-0"


def test_two_echoes_of_one_child_across_two_beams_are_both_the_child() -> None:
    """One body across two beams makes two echoes in its gate: on a ring whose beams merge
    both are the child (counted as two bodies, they stopped the robot beside a child the
    camera tracks: the review of b9a6df9, M1)."""
    child = seen(centre_at(0.2), 0.2)
    own = echo(centre_at(0.2) - 0.03, 0.2)
    split = msgspec.structs.replace(own, id="echo-0.s1")
    verdict, _ = supervise(towards(0.2), ringed(child, echoes=[own, split]), supervisor=narrow())
    assert verdict.human == "child" and verdict.zone is SafetyZone.SLOW


def spun(supervisor: SafetySupervisor) -> float:
    """Spin the robot on the spot for 700 ms (nothing in view: nothing limits), up to 1.5
    rad/s by 600 ms; how far it turned from 600 to 700 ms, rad (0.15)."""
    headings = {}
    for tick in range(35):
        now_ms = tick * TICK_MS
        supervise(Velocity(0.0, 0.0, 1.5), ringed(), now_ms=now_ms, supervisor=supervisor)
        headings[now_ms + TICK_MS] = supervisor.reckoned_pose[2]
    return headings[700] - headings[600]


def test_the_turn_since_the_cameras_frame_counts() -> None:
    """The camera's frame at 600 ms, the ring's echo of the same child at 700 ms, the
    robot spinning at 1.5 rad/s: the echo lies 0.15 rad farther in than the child did in
    the frame that saw them. The frame's bearing decides: at 0.35 rad the camera saw all the
    beam may hold; at 0.55 rad it did not (the echo's own bearing, 0.4, would pass). (The
    echo reads 12 cm nearer, within the 0.14 m gate: kept, its fresher margin binds.)"""
    for bearing, explained in ((0.35, True), (0.55, False)):
        supervisor = narrow()
        turn = spun(supervisor)
        assert 0.149 < turn < 0.151
        child = seen(centre_at(0.32), bearing, at_ms=600)
        own = echo(centre_at(0.32) - 0.12, bearing - turn, at_ms=700)  # fresher: it'd bind
        world_map = ringed(child, echoes=[own])
        verdict, _ = supervise(
            towards(bearing - turn), world_map, now_ms=700, supervisor=supervisor
        )
        assert verdict.human == ("child" if explained else "Obstacle/echo-0"), bearing


def test_without_a_scenario_the_ring_is_taken_for_wide_sonars_and_the_camera_narrow() -> None:
    """A pipeline without a scenario assumes 60-degree sonars and a 1 rad camera: no beam
    fits in the view, so every echo is kept, even one that a tracked child's reading
    explains (conservative: the robot stops at the echo's distance)."""
    config = SafetyConfig(robot_radius_m=0.3).filled()
    assert config.sonar_beam_rad == math.pi / 3 and config.camera_fov_rad == 1.0
    child = seen(centre_at(0.2), 0.0)
    own = echo(centre_at(0.2) - 0.03, 0.0)
    verdict, _ = supervise(towards(0.0), ringed(child, echoes=[own]))
    assert verdict.human == "Obstacle/echo-0"
