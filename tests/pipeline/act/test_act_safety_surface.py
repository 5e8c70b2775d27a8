"""The safety supervisor and a ring that reports surfaces (``sonar_reports_surface``): an
echo's range is the nearest surface its sonar heard, so the body that made it has its
centre a radius farther out, and the echo's centre is placed there (its chord taken at
that range): a child's radius counted once, not twice (``pipeline/act/echoes.py``). The
ring here is the simulator's own (``scenarios.simulation.sensors.beam_echoes``: 12 sonars,
each the nearest point of each disc within its beam, side beams included), scanning at
10 Hz while the robot drives on its dead reckoning."""

from __future__ import annotations

import math

import msgspec
from oimi.pipeline.act.limits import Velocity
from oimi.pipeline.act.safety import SafetySupervisor
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.events import SafetyZone
from oimi.pipeline.messages import Obstacle, Sonar, WorldMap
from oimi.scenarios.simulation.sensors import beam_echoes
from supervision import LIMITS, TICK_MS, echo, room, supervise

BEAMS = 12
RING = SafetyConfig(robot_radius_m=0.3, camera_fov_rad=2.2, sonar_beam_rad=math.tau / BEAMS)
"""12 sonars of 30 degrees and the scenarios' camera; the ring's convention unstated (False:
the echo's centre at its range, either convention covered)."""
SURFACE = msgspec.structs.replace(RING, sonar_reports_surface=True)
"""The same ring, stated to report surfaces (the simulator's)."""
CHILD_M = 0.25
SCAN_TICKS = 5
"""The ring scans every 100 ms."""


def ringed(*echoes: Obstacle) -> WorldMap:
    world_map = room()
    world_map.sonars.append(Sonar(id="ring", isonline=True))
    world_map.obstacles += list(echoes)
    return world_map


def scanned(child: tuple[float, float], pose: tuple[float, float, float], at_ms: int):
    """What the ring at ``pose`` hears of a child standing at ``child``, as the map's echoes
    (range and bearing from the robot, stamped ``at_ms``)."""
    body = ("echo-0", child[0], child[1], CHILD_M, False)
    found = []
    for ident, x, y in beam_echoes([body], pose, BEAMS, 3.0):
        rho = math.hypot(x - pose[0], y - pose[1])
        theta = math.remainder(math.atan2(y - pose[1], x - pose[0]) - pose[2], math.tau)
        found.append(msgspec.structs.replace(echo(rho, theta, at_ms=at_ms), id=ident))
    return found


def drive(config: SafetyConfig, child: tuple[float, float], request: Velocity, ticks: int):
    """The robot asks for ``request`` for ``ticks`` by a child standing still at ``child``:
    the nearest the robot's disc came to the child's, m (their surface distance), and where
    it ended (its dead reckoning, which the test takes for its motion)."""
    supervisor = SafetySupervisor(config, LIMITS, tick_ms=TICK_MS)
    nearest = math.inf
    echoes: list[Obstacle] = []
    for tick in range(ticks):
        now_ms = tick * TICK_MS
        pose = supervisor.reckoned_pose
        nearest = min(nearest, math.dist(pose[:2], child) - 0.3 - CHILD_M)
        if tick % SCAN_TICKS == 0:
            echoes = scanned(child, pose, now_ms)
        supervise(request, ringed(*echoes), now_ms=now_ms, supervisor=supervisor)
    return nearest, supervisor.reckoned_pose


def test_a_surface_echo_lets_the_robot_nearer_but_never_into_the_child() -> None:
    """A child 0.6 m ahead, surface to the robot's centre (0.85 m centre to centre, 0.3 m
    surface to surface), the robot asking to drive at them at 0.5 m/s. The echo's centre
    kept at its range drew the child's disc 0.25 m nearer than they are: already in the
    stop zone (a protective stop), and the robot stood 0.3 m off. Placed a radius beyond,
    the echo is the child's disc, less the errors and what a drive across may close on its
    arc: the robot slows and comes nearer, never into the stop zone of the child's disc
    (the walk a 10 Hz scan's echo may hide stops it 0.25 m off)."""
    ahead = Velocity(0.5, 0.0, 0.0)
    verdict, _ = supervise(ahead, ringed(echo(0.6, 0.0)), config=RING)
    assert verdict.zone is SafetyZone.STOP and verdict.velocity.v_x == 0.0
    verdict, _ = supervise(ahead, ringed(echo(0.6, 0.0)), config=SURFACE)
    assert verdict.zone is SafetyZone.SLOW and 0.0 < verdict.velocity.v_x <= 0.2
    assert 0.2 < verdict.surface_distance_m <= 0.3 - 0.02 - 0.02  # (less both errors)
    unstated, _ = drive(RING, (0.85, 0.0), ahead, 150)
    stated, _ = drive(SURFACE, (0.85, 0.0), ahead, 150)
    assert unstated > 0.29  # it never moved
    assert 0.1 <= stated < unstated - 0.04


def test_driving_across_past_a_surface_echo_keeps_out_of_the_childs_disc() -> None:
    """The robot asks to drive across at 0.3 m/s, past a child 0.8 m ahead and 0.8 m to
    the left (0.25 m surface to surface where it passes). A disc tangent at the surface
    heard comes nearer than that point as the robot moves across: kept a disc, the echo
    bends the drive out and slows it while the child is near, and the robot passes them
    without entering their stop zone. With the echo's centre at its range, the child's disc
    drawn a radius nearer, it is bent out so far and slowed so much that it never passes."""
    child = (0.8, 0.8)
    across = Velocity(0.0, 0.3, 0.0)
    nearest, (_, y, _) = drive(SURFACE, child, across, 300)
    assert y > child[1] + 0.5  # past the child
    assert nearest >= 0.1
    _, (_, y, _) = drive(RING, child, across, 300)
    assert y < child[1]
