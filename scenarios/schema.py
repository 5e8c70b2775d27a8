"""The scenario file's schema: strict, frozen msgspec Structs decoded from TOML.

Every length is in metres (``_m``), time in seconds (``_s``) or milliseconds
(``_ms``), speed in m/s (``_mps``), angular speed in rad/s (``_radps``), rates
in Hz (``_hz``), masses in kg (``_kg``). The arena's origin is its lower-left
corner: x to the right, y up, angles counter-clockwise from +x. Distances
between bodies are measured centre to centre. ``docs/scenario-files.md``
documents every field.

Ranges are declared on the fields (the ``Annotated`` aliases below) and checked
when a file or an override is decoded; every float must also be finite
(``scenarios.loader`` refuses NaN and infinities before decoding). The robot's
physical ceiling is in ``scenarios.profile``.

Long module: the scenario file's whole schema is one tagged Struct tree that
msgspec decodes in one go; a file per section would only scatter the ranges it declares.
"""

from __future__ import annotations

import enum
from typing import Annotated, Final

import msgspec
from msgspec import Meta
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.events import Button, MotionSource, Pad, SafetyZone
from oimi.pipeline.messages import TouchType
from oimi.pipeline.operator.commands import OperatorCommand

DEFAULT_TICK_HZ: Final = 50
"""Simulated clock rate when a scenario gives none (a tick of 20 ms)."""


class Spec(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Base of every part of a scenario file: unknown keys are errors."""


# ---------------------------------------------------------------------- ranges

MAX_ROOM_M: Final = 100.0
"""Largest side of the arena (and of anything in it), m."""
MAX_SESSION_S: Final = 86_400.0
"""Longest session (and battery), s: one day."""
MAX_RATE_HZ: Final = 1000.0
"""Fastest sensor rate: the clock ticks at most every millisecond."""
MIN_RATE_HZ: Final = 0.001
"""Slowest camera rate: a frame every 1,000 s (the safety supervisor keeps readings and its
odometry for a few of its periods; a slower camera is no sensor for it)."""
MAX_HUMAN_SPEED_MPS: Final = 10.0
"""Faster than any child or therapist runs."""
MAX_MASS_KG: Final = 1000.0
"""Heaviest movable object."""
MIN_SIZE_M: Final = 0.001
"""Smallest radius of a body that moves (smaller ones have no moment of inertia)."""
MIN_MASS_KG: Final = 0.001
"""Lightest body that moves."""

Positive = Annotated[float, Meta(gt=0)]
"""A rate, period, size, mass or duration: more than zero."""
NonNegative = Annotated[float, Meta(ge=0)]
"""A time, distance, noise or threshold that may be zero."""
Fraction = Annotated[float, Meta(ge=0, le=1)]
"""A probability or a fraction, 0 to 1."""
Axis = Annotated[float, Meta(ge=-1, le=1)]
"""A joystick axis, -1 to 1."""
Count = Annotated[int, Meta(ge=0)]
"""A count or an index: zero or more."""
PositiveInt = Annotated[int, Meta(gt=0)]
RoomSize = Annotated[float, Meta(gt=0, le=MAX_ROOM_M)]
BodySize = Annotated[float, Meta(ge=0, le=MAX_ROOM_M)]
"""A size that may be zero (a box's sides when it is a disc)."""
Rate = Annotated[float, Meta(ge=MIN_RATE_HZ, le=MAX_RATE_HZ)]
ScanRate = Annotated[int, Meta(gt=0, le=int(MAX_RATE_HZ))]
SessionTime = Annotated[float, Meta(gt=0, le=MAX_SESSION_S)]
Span = Annotated[float, Meta(ge=0, le=MAX_SESSION_S)]
"""A time or length of simulated time that may be zero, s (at most a day, as a session)."""
HumanSpeed = Annotated[float, Meta(gt=0, le=MAX_HUMAN_SPEED_MPS)]
Mass = Annotated[float, Meta(ge=MIN_MASS_KG, le=MAX_MASS_KG)]
Radius = Annotated[float, Meta(ge=MIN_SIZE_M, le=MAX_ROOM_M)]
"""The radius of a body that moves: a robot, a human, an object."""
DurationMs = Annotated[int, Meta(ge=0, le=int(MAX_SESSION_S * 1000))]
MAX_SONAR_BEAMS: Final = 360
"""Most sonars a ring holds (one a degree)."""
SonarBeams = Annotated[int, Meta(ge=0, le=MAX_SONAR_BEAMS)]

UNITS: Final = (
    ("_radps2", "rad/s²"),
    ("_mps2", "m/s²"),
    ("_radps", "rad/s"),
    ("_mps", "m/s"),
    ("_per_s", "fraction kept per s"),
    ("_rad", "rad"),
    ("_ms", "ms"),
    ("_m", "m"),
    ("_s", "s"),
    ("_hz", "Hz"),
    ("_fps", "frames/s"),
    ("_kg", "kg"),
    ("_px", "px"),
    ("_probability", "0 to 1"),
    ("waypoints", "m"),
    ("left_x", "-1 to 1"),
    ("left_y", "-1 to 1"),
    ("right_x", "-1 to 1"),
    ("at_least", "count"),
    ("at_most", "count"),
    ("position", "index"),
)
"""A field's unit by the end of its name (the first match wins)."""


def unit_of(field: str) -> str:
    """The unit of a field named ``field`` (``"m/s"`` for ``max_speed_mps``), or ``""``."""
    return next((unit for end, unit in UNITS if field.endswith(end)), "")


# ----------------------------------------------------------------------- codes


class ObstacleKind(enum.StrEnum):
    """Furniture of a therapy room (all static)."""

    TABLE = "table"
    CHAIR = "chair"
    SHELF = "shelf"
    BOX = "box"
    PILLAR = "pillar"


class Role(enum.StrEnum):
    """Who a human is in the session."""

    CHILD = "child"
    THERAPIST = "therapist"


class SensorKind(enum.StrEnum):
    CAMERA = "camera"
    SONAR = "sonar"


class FaultMode(enum.StrEnum):
    """What a fault event does to a sensor."""

    OFFLINE = "offline"
    """Stops producing readings and reports ``isonline`` = ``s_false``."""
    FROZEN = "frozen"
    """Keeps reporting, but repeats its last reading (no status change)."""
    SILENT = "silent"
    """Its link dies: no more readings and no status at all (the map keeps its last
    ``isonline``, as a robot's would)."""
    ONLINE = "online"
    """Back to normal; reports ``isonline`` = ``s_true``."""


# ----------------------------------------------------------------------- world


class ObstacleSpec(Spec, kw_only=True):
    """A static piece of furniture: a box (``width_m`` x ``height_m``) or a disc (``radius_m``)."""

    id: str
    kind: ObstacleKind = ObstacleKind.TABLE
    x_m: float
    """Centre, m."""
    y_m: float
    width_m: BodySize = 0.0
    """Extent along x before rotation, m (boxes)."""
    height_m: BodySize = 0.0
    """Extent along y before rotation, m (boxes; top view, not the furniture's height)."""
    radius_m: BodySize = 0.0
    """Radius, m (discs: set instead of width/height)."""
    angle_rad: float = 0.0
    """Rotation of a box, counter-clockwise."""


class ObjectSpec(Spec, kw_only=True):
    """A movable round object (a ball): a dynamic disc that rolls when pushed and stops."""

    id: str
    category: str = "ball"
    x_m: float
    y_m: float
    radius_m: Radius = 0.11
    mass_kg: Mass = 0.45
    istarget: bool = False
    """Reported to the map as the object's ``istarget``."""
    damping_per_s: Fraction = 0.6
    """Fraction of its speed a rolling object keeps after one second (0 to 1)."""
    rolling_decel_mps2: NonNegative = 0.2
    """Constant rolling resistance, m/s² (makes it stop in finite time)."""


class WorldSpec(Spec, kw_only=True):
    """The therapy room: a walled rectangle with furniture and objects."""

    width_m: RoomSize = 6.0
    height_m: RoomSize = 5.0
    exit_x_m: float = 0.0
    """Where humans who ``leave`` walk to (default: the middle of the left wall)."""
    exit_y_m: float | None = None
    """None: half of ``height_m``."""
    obstacles: list[ObstacleSpec] = []
    objects: list[ObjectSpec] = []

    @property
    def exit_point(self) -> tuple[float, float]:
        """Where humans who ``leave`` walk to, m."""
        return (self.exit_x_m, self.height_m / 2 if self.exit_y_m is None else self.exit_y_m)


class RobotSpec(Spec, kw_only=True):
    """The omni-directional robot (thesis 5.2): start pose and limits."""

    x_m: float | None = None
    """Start position; None: the arena's centre."""
    y_m: float | None = None
    theta_rad: float = 0.0
    """Start heading, counter-clockwise from +x."""
    radius_m: Radius = 0.3
    mass_kg: Mass = 20.0
    max_speed_mps: Positive = 0.5
    max_angular_speed_radps: Positive = 1.5
    max_accel_mps2: Positive = 1.0
    max_angular_accel_radps2: Positive = 3.0
    battery_s: Span = 3600.0
    """Battery time at the start, s (reported as ``batterytimeleft`` in ms)."""
    safety: SafetyConfig = msgspec.field(default_factory=SafetyConfig)
    """The safety supervisor's zones (``[robot.safety]``; always on, see
    ``pipeline.act.safety``); its ``robot_radius_m`` defaults to ``radius_m``."""


class SensorSpec(Spec, kw_only=True):
    """The simulated sensors: a front camera (humans, objects) and a sonar ring (every body:
    the room's obstacles, and people as anonymous echoes)."""

    range_m: Positive = 5.0
    """Camera range, m."""
    fov_rad: Positive = 2.2
    """Camera field of view, centred on the heading, rad."""
    rate_hz: Rate = 10.0
    """Camera frame rate of entity updates, Hz."""
    noise_rho_m: NonNegative = 0.0
    """Standard deviation of the gaussian noise on distances, m."""
    noise_theta_rad: NonNegative = 0.0
    """Standard deviation of the gaussian noise on bearings, rad."""
    dropout_probability: Fraction = 0.0
    """Probability that one detection is lost (0 to 1)."""
    camera_id: str = "front"
    camera_width_px: PositiveInt = 640
    camera_height_px: PositiveInt = 480
    camera_fps: PositiveInt = 30
    sonar_id: str = "ring"
    sonar_range_m: Positive = 3.0
    """Sonar range, all around the robot, m."""
    sonar_scan_hz: ScanRate = 5
    """Sonar scans per second (reported as ``scanfrequency``)."""
    sonar_beams: SonarBeams = 0
    """How many sonars the ring has, evenly spaced (the first straight ahead), each
    reporting the range to the nearest surface its beam (``2 pi / sonar_beams`` wide)
    reaches, on its axis, as a real ring does: two bodies in one beam make one echo, one
    across two beams two, and one behind a nearer body in every beam it reaches none; 0: an
    ideal ring that reports every body apart, once, at its centre
    (``scenarios.simulation.sensors``)."""
    status_period_s: SessionTime = 1.0
    """How often the robot's status (speed, battery, elapsed time) and each sensor's
    ``isonline`` are reported, s (the safety supervisor takes a sensor whose status stops
    coming for offline)."""


# ---------------------------------------------------------------- behaviours


class Segment(Spec, tag_field="kind", kw_only=True):
    """A timed piece of a human's behaviour; it runs from ``at_s`` until the next one."""

    at_s: Span = 0.0
    speed_mps: HumanSpeed | None = None
    """Walking speed; None: the human's ``max_speed_mps``."""


class Stand(Segment, tag="stand", kw_only=True):
    """Stand still."""


class Waypoints(Segment, tag="waypoints", kw_only=True):
    """Walk through the points in order, then stand (or start over when ``loop``)."""

    waypoints: list[tuple[float, float]]
    """``[[x_m, y_m], ...]``"""
    loop: bool = False


class Approach(Segment, tag="approach", kw_only=True):
    """Walk towards the robot until ``distance_m`` from it, then stand."""

    distance_m: Positive = 0.8


class Wander(Segment, tag="wander", kw_only=True):
    """Walk to random places in the arena, pausing at each."""

    pause_s: Span = 1.0
    margin_m: NonNegative = 0.5
    """Keep targets this far from the walls, m."""


class Follow(Segment, tag="follow", kw_only=True):
    """Keep within ``distance_m`` of the robot: walk towards it whenever farther."""

    distance_m: Positive = 1.0


class Leave(Segment, tag="leave", kw_only=True):
    """Walk to the arena's exit and leave the room (no longer simulated or seen)."""


class Custom(Segment, tag="custom", kw_only=True):
    """A behaviour an extension adds (``ext.behaviour(name, factory)``), by its name."""

    name: str
    options: dict[str, float | str] = {}
    """Handed to the behaviour's factory."""


BehaviourSegment = Stand | Waypoints | Approach | Wander | Follow | Leave | Custom


class HumanSpec(Spec, kw_only=True):
    """A child or a therapist: a kinematic disc moved by its behaviour."""

    id: str
    role: Role = Role.CHILD
    x_m: float
    y_m: float
    radius_m: Radius = 0.25
    max_speed_mps: HumanSpeed = 1.0
    touchtype: TouchType = TouchType.P
    """Touch class reported when this human bumps into the robot."""
    behaviour: list[BehaviourSegment] = []
    """Timed segments, ``at_s`` non-decreasing; none: stand."""


# ---------------------------------------------------------------- activities


class ActivitySpec(Spec, kw_only=True):
    """An activity to load: a script file or a generator (exactly one of the two)."""

    script: str | None = None
    """``activities/x.json`` or ``.txt``, relative to the scenario's folder or the library."""
    generator: str | None = None
    """A script generator's name (e.g. ``test_dance``)."""
    options: dict[str, str] = {}
    """Generator options."""


# -------------------------------------------------------------------- events


class EventSpec(Spec, tag_field="kind", kw_only=True):
    """Something that happens at ``at_s`` of simulated time."""

    at_s: Span


class OperatorEvent(EventSpec, tag="operator", kw_only=True):
    """A command from the operator's app (thesis 5.1), as the App Interface receives it:
    ``command = { cmd = "add", activity = "test_dance" }``. The session numbers it."""

    command: OperatorCommand


class JoystickEvent(EventSpec, tag="joystick", kw_only=True):
    """The pad's sticks and buttons, held for ``hold_s`` then released (0: until changed)."""

    left_x: Axis = 0.0
    """-1 to 1, right positive."""
    left_y: Axis = 0.0
    """-1 to 1, forward positive."""
    right_x: Axis = 0.0
    """-1 to 1, right positive."""
    buttons: list[Button] = []
    hold_s: Span = 0.0

    @property
    def pad(self) -> Pad:
        """The pad's state this event sets."""
        return Pad(
            left_x=self.left_x,
            left_y=self.left_y,
            right_x=self.right_x,
            buttons=tuple(self.buttons),
        )


class TouchEvent(EventSpec, tag="touch", kw_only=True):
    """A human touches the robot (reported as RobotStatus ``touch``)."""

    human: str
    touchtype: TouchType = TouchType.T
    duration_ms: DurationMs = 500


class FaultEvent(EventSpec, tag="fault", kw_only=True):
    """A sensor goes offline, freezes, falls silent, or comes back online."""

    sensor: SensorKind
    id: str | None = None
    """The sensor's id; None: the only one of that kind."""
    mode: FaultMode


class BehaviourEvent(EventSpec, tag="behaviour", kw_only=True):
    """A human switches to a new behaviour segment now (later timed segments still apply)."""

    human: str
    segment: BehaviourSegment


Event = OperatorEvent | JoystickEvent | TouchEvent | FaultEvent | BehaviourEvent


# -------------------------------------------------------------- expectations


class ExpectSpec(Spec, tag_field="kind", kw_only=True):
    """A verdict checked at the end of the session."""

    name: str = ""
    """A label for reports (default: derived from the kind)."""


class GoalReached(ExpectSpec, tag="goal_reached", kw_only=True):
    goal: str
    """The goal's ``goalid``."""
    by_s: Span | None = None
    """Deadline; None: by the end."""


class ActivityCompleted(ExpectSpec, tag="activity_completed", kw_only=True):
    activity: str
    by_s: Span | None = None


class RuleFired(ExpectSpec, tag="rule_fired", kw_only=True):
    rule: str
    """The rule instance's id."""
    at_least: Count = 1
    at_most: Count | None = None
    after_s: Span | None = None
    """Count only the ticks from this time on; None: from the start."""
    by_s: Span | None = None
    """Count only the ticks up to this time; None: to the end."""


class Between(enum.StrEnum):
    """What a ``min_distance`` measures."""

    CENTRES = "centres"
    """Centre to centre (the bodies' radii included)."""
    SURFACES = "surfaces"
    """Surface to surface, as the run's summary and ``oimi analyse`` report it (0: touching)."""


class MinDistance(ExpectSpec, tag="min_distance", kw_only=True):
    """The robot is never closer than ``at_least_m`` to the human(s), centre to centre or
    surface to surface (``between``)."""

    human: str | None = None
    """None: every human."""
    at_least_m: NonNegative
    between: Between = Between.CENTRES


class MaxSpeed(ExpectSpec, tag="max_speed", kw_only=True):
    """The robot's speed never exceeds ``at_most_mps``."""

    at_most_mps: NonNegative


class NoRejectedInputs(ExpectSpec, tag="no_rejected_inputs", kw_only=True):
    """No update or command was rejected (nothing on ``/log`` at warning or above)."""


class RobotInArena(ExpectSpec, tag="robot_in_arena", kw_only=True):
    """The robot never leaves the arena."""


class ActivityState(ExpectSpec, tag="activity_state", kw_only=True):
    """An activity is in ``state`` (``loaded``, ``running``, ``completed``, ``interrupted``)."""

    activity: str
    state: str
    at_s: Span | None = None
    """When to check; None: at the end."""


class SafetyIntervened(ExpectSpec, tag="safety_intervened", kw_only=True):
    """The safety supervisor limited the robot's velocity (episodes on ``/safety``)."""

    zone: SafetyZone | None = None
    """Count only episodes that reached this zone (``stop``, ``slow``...); None: any."""
    source: MotionSource | None = None
    """Count only episodes of this source (``script``, ``rule``, ``joystick``); None: any."""
    at_least: int = 1
    at_most: int | None = None


class NoRobotInitiatedContact(ExpectSpec, tag="no_robot_initiated_contact", kw_only=True):
    """No contact episode that the robot initiated (``pipeline.proximity``)."""

    human: str | None = None
    """None: every human."""


class ClosingSpeedAtContact(ExpectSpec, tag="closing_speed_at_contact", kw_only=True):
    """Every contact episode closed the gap at ``at_most_mps`` or less (``pipeline.proximity``)."""

    human: str | None = None
    """None: every human."""
    at_most_mps: NonNegative


Expectation = (
    GoalReached
    | ActivityCompleted
    | RuleFired
    | MinDistance
    | MaxSpeed
    | NoRejectedInputs
    | RobotInArena
    | ActivityState
    | SafetyIntervened
    | NoRobotInitiatedContact
    | ClosingSpeedAtContact
)


# ------------------------------------------------------------------ scenario


class Scenario(Spec, kw_only=True):
    """A whole scenario file."""

    name: str
    description: str = ""
    seed: int = 0
    """Seeds every random generator of the session (see
    ``scenarios.simulation.world.stream_rng``)."""
    duration_s: SessionTime = 60.0
    tick_hz: PositiveInt = DEFAULT_TICK_HZ
    """Simulated clock rate; must divide 1000 (ticks are whole milliseconds)."""
    world: WorldSpec = msgspec.field(default_factory=WorldSpec)
    robot: RobotSpec = msgspec.field(default_factory=RobotSpec)
    sensors: SensorSpec = msgspec.field(default_factory=SensorSpec)
    humans: list[HumanSpec] = []
    activities: list[ActivitySpec] = []
    events: list[Event] = []
    expect: list[Expectation] = []
    extensions: list[str] = []
    """Extensions the scenario needs: paths relative to this file, or module names."""

    @property
    def tick_ms(self) -> int:
        """Length of one tick, ms."""
        return 1000 // self.tick_hz

    @property
    def ticks(self) -> int:
        """Number of ticks in the session."""
        return round(self.duration_s * 1000) // self.tick_ms
