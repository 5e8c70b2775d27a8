"""Hand-made maps and a supervisor for the safety supervisor's tests (``test_act_safety*``)."""

from __future__ import annotations

import math

from oimi.pipeline.act.limits import RobotLimits, Velocity
from oimi.pipeline.act.safety import SafetySupervisor
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.events import MotionSource
from oimi.pipeline.messages import Camera, Human, Obstacle, Pose, WorldMap

TICK_MS = 20
LIMITS = RobotLimits()
# robot 0.3 + human 0.25 + margin (0.02 sensing + 1 m/s * one tick of age = 0.04)
CONFIG = SafetyConfig(robot_radius_m=0.3)
FRONT = SafetyConfig(robot_radius_m=0.3, camera_fov_rad=2.2)
"""The scenarios' front camera (2.2 rad): with a sonar down, the robot drives within 24
degrees of straight ahead (1 rad, the default: nowhere)."""
MARGIN_M = 0.02 + 1.0 * TICK_MS / 1000
RADII_M = 0.3 + 0.25


def centre_at(surface_m: float) -> float:
    """The centre distance a fresh reading gives for a supervisor surface distance."""
    return surface_m + RADII_M + MARGIN_M


def seen(rho: float, theta: float = 0.0, *, at_ms: int = 0, ident: str = "child") -> Human:
    pose = Pose(positionrho=rho, positiontheta=theta, positionchangetime=at_ms)
    return Human(
        id=ident,
        creationtime=0,
        positionrho=rho,
        positiontheta=theta,
        positionchangetime=at_ms,
        poses=[pose],
    )


def room(*humans: Human, camera: bool = True) -> WorldMap:
    return WorldMap(cameras=[Camera(id="front", isonline=camera)], humans=list(humans))


def live(world_map: WorldMap, now_ms: int) -> dict[tuple[str, str], int]:
    """Every sensor of the map heard from at ``now_ms`` (``MapProducer.heard``)."""
    heard = {("Camera", camera.id): now_ms for camera in world_map.cameras}
    return heard | {("Sonar", sonar.id): now_ms for sonar in world_map.sonars}


def supervise(  # every sensor heard from, scanned and framing at now_ms unless told
    velocity: Velocity,
    world_map: WorldMap,
    *,
    now_ms: int = 0,
    heard: dict[tuple[str, str], int] | None = None,
    scanned: dict[str, int] | None = None,
    framed: dict[str, int] | None = None,
    source: MotionSource = MotionSource.SCRIPT,
    supervisor: SafetySupervisor | None = None,
    config: SafetyConfig = CONFIG,
):
    """The supervisor's verdict; ``scanned`` and ``framed``: each sonar's and camera's
    latest heartbeat by id (``MapProducer.beats``); ``config``: a new supervisor's."""
    supervisor = supervisor or SafetySupervisor(config, LIMITS, tick_ms=TICK_MS)
    if scanned is None:
        scanned = {s.id: now_ms for s in world_map.sonars}
    if framed is None:
        framed = {c.id: now_ms for c in world_map.cameras}
    beats = {("Sonar", ident): at for ident, at in scanned.items()}
    return supervisor.supervise(
        velocity,
        world_map,
        heard=live(world_map, now_ms) if heard is None else heard,
        beats=beats | {("Camera", ident): at for ident, at in framed.items()},
        tick=now_ms // TICK_MS,
        now_ms=now_ms,
        source=source,
    )


def echo(rho: float, theta: float = math.pi, *, at_ms: int = 0, fixed: bool = False) -> Obstacle:
    """A sonar echo (an obstacle) at ``rho`` m, behind the robot unless told."""
    pose = Pose(positionrho=rho, positiontheta=theta, positionchangetime=at_ms)
    return Obstacle(
        id="echo-0",
        creationtime=0,
        positionrho=rho,
        positiontheta=theta,
        positionchangetime=at_ms,
        poses=[pose],
        isfixed=fixed,
    )
