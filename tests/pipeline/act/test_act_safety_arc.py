"""The safety supervisor and a real ring's echo (``sonar_beam_rad`` > 0): a sonar gives a
range, not a bearing, so an echo is an arc: what made it lies at its range anywhere within
half a beam of its bearing (its beam's axis). The echo's margin grows by the chord that
covers the arc, and a tracked child's gate is measured to the arc (``pipeline/act/echoes.py``)."""

from __future__ import annotations

import math

import pytest
from oimi.pipeline.act.echoes import EchoSorter
from oimi.pipeline.act.limits import Velocity
from oimi.pipeline.act.looking import SensorWatch
from oimi.pipeline.act.reckoning import DeadReckoning
from oimi.pipeline.act.safety import SafetySupervisor
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.events import SafetyZone
from oimi.pipeline.messages import Sonar, WorldMap
from supervision import LIMITS, TICK_MS, echo, room, seen, supervise

BEAM = math.tau / 12
REAL = SafetyConfig(robot_radius_m=0.3, camera_fov_rad=2.2, sonar_beam_rad=BEAM)
"""12 sonars of 30 degrees (an echo up to 15 degrees from its body) and the scenarios'
camera (2.2 rad)."""


DEAD_RECKONING = DeadReckoning(LIMITS, tick_ms=TICK_MS, kept_ms=1000, error=0.05, push_mps=1.0)
CAMERAS = SensorWatch("Camera", 500, 0, TICK_MS)


def ringed(*humans, echoes=()) -> WorldMap:
    world_map = room(*humans)
    world_map.sonars.append(Sonar(id="ring", isonline=True))
    world_map.obstacles += list(echoes)
    return world_map


def real() -> SafetySupervisor:
    return SafetySupervisor(REAL, LIMITS, tick_ms=TICK_MS)


def towards(bearing: float, speed: float) -> Velocity:
    return Velocity(speed * math.cos(bearing), speed * math.sin(bearing), 0.0)


@pytest.mark.parametrize("echo_m", [0.6, 0.35])
def test_a_child_half_a_beam_off_their_echos_bearing_is_not_closed_on(echo_m: float) -> None:
    """A child behind the robot, 0.6 m centre to centre (in the stop zone), 15 degrees off
    the axis of the sonar that hears them: it reports them on its axis, at their centre's
    range (0.6 m, a driver that reports centres) or their surface's (0.35 m). Driving at 5
    cm/s, 85 degrees off the child, points 100 degrees off the echo: taken for the child's
    centre, the echo let it through unlimited, closing on the child at 4 mm/s inside the
    stop zone. Its disc now covers the arc: the drive is bent away, and closes on no point
    of it."""
    child = math.pi - BEAM / 2
    drive = towards(child - math.radians(85), 0.05)
    verdict, _ = supervise(drive, ringed(echoes=[echo(echo_m, math.pi)]), supervisor=real())
    assert verdict.zone is SafetyZone.STOP and verdict.human == "Obstacle/echo-0"
    for off in (-BEAM / 2, 0.0, BEAM / 2):  # wherever on the arc it lies
        bearing = math.pi + off
        closing = verdict.velocity.v_x * math.cos(bearing) + verdict.velocity.v_y * math.sin(
            bearing
        )
        assert closing <= 1e-9, off


def test_an_echo_at_a_tracked_childs_surface_on_its_beams_axis_is_that_child() -> None:
    """The camera sees a child 1 m away, 10 degrees left; the sonar ahead hears their
    surface (0.75 m) and reports it on its axis: 0.29 m from the child's centre, beyond the
    gate of a centre (0.04 m), it was kept as a second body and stopped the robot beside
    the child. Measured to the arc (the child's bearing is within half a beam of the axis:
    0.25 m) and a body's radius wider, it is the child (the camera saw all the beam)."""
    child = seen(1.0, math.radians(10))
    own = echo(0.75, 0.0)
    verdict, _ = supervise(towards(0.17, 0.5), ringed(child, echoes=[own]), supervisor=real())
    assert verdict.human == "child" and verdict.zone is SafetyZone.SLOW


def test_an_echo_farther_from_a_tracked_child_than_their_radius_is_another_body() -> None:
    """0.6 m ahead, on the axis of the sonar that sees the child 1 m away: 0.4 m from their
    centre, more than a body's radius and both readings' errors (0.29 m). Not the child:
    kept, it binds (a protective stop)."""
    child = seen(1.0, 0.0)
    other = echo(0.6, 0.0)
    verdict, _ = supervise(towards(0.0, 0.5), ringed(child, echoes=[other]), supervisor=real())
    assert verdict.human == "Obstacle/echo-0" and verdict.zone is SafetyZone.STOP


def test_an_echos_arc_is_the_chord_of_half_a_beam_at_its_range() -> None:
    """``2 rho sin(beam / 4)``: the farthest a point at the echo's range within half a beam
    of its axis lies from it (0.26 m at 1 m for 30-degree beams); none for a human (the
    camera gives a bearing) nor on the ideal ring."""
    config = REAL.filled()
    sorter = EchoSorter(config, DEAD_RECKONING, CAMERAS)
    assert sorter.arc_m(echo(1.0)) == pytest.approx(2 * math.sin(BEAM / 4))
    assert sorter.arc_m(echo(1.0)) == pytest.approx(math.dist((1, 0), polar(1.0, BEAM / 2)))
    assert sorter.arc_m(seen(1.0)) == 0.0
    ideal = SafetyConfig(robot_radius_m=0.3, sonar_beam_rad=0.0).filled()
    sorter = EchoSorter(ideal, DEAD_RECKONING, CAMERAS)
    assert sorter.arc_m(echo(1.0)) == 0.0


def polar(rho: float, bearing: float) -> tuple[float, float]:
    return (rho * math.cos(bearing), rho * math.sin(bearing))


def test_an_echos_distance_is_its_arcs_less_what_a_drive_across_may_close() -> None:
    """An echo 1 m ahead: every point of its arc lies 1 m away, not the disc's 1 m less its
    chord (0.26 m: across the line of sight, not along it). What the braking bound does not
    count is what a drive moving across that line may close on a point of the arc off it:
    its way at the top speed (a tick and braking: 0.135 m) times the sine of the angle the
    disc spans (0.26): 3.5 cm. The echo's surface distance is 1 - 0.55 - 0.04 - 0.035."""
    way = 0.5 * (TICK_MS / 1000 + 0.5 / 2)
    expected = 1.0 - 0.55 - 0.04 - way * 2 * math.sin(BEAM / 4)
    verdict, _ = supervise(towards(0.0, 0.5), ringed(echoes=[echo(1.0, 0.0)]), supervisor=real())
    assert verdict.zone is SafetyZone.SLOW and verdict.human == "Obstacle/echo-0"
    assert verdict.surface_distance_m == pytest.approx(expected, abs=1e-4)
