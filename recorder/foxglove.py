"""Foxglove's well-known messages (the parts we use) and how our events map onto them.

The Structs mirror ``recorder/foxglove_schemas/*.json``: every field a schema
requires is present (empty lists where we draw nothing), enums are integers and
times are ``{"sec", "nsec"}``. The ``world`` frame is the arena, z up, its lower-left
corner at the origin; the arena is drawn in it, and each body in its own frame
(``robot``, ``human/<id>``, ``object/<id>``), which ``/foxglove/tf`` moves.
"""

from __future__ import annotations

import enum
import functools
import math
from collections.abc import Callable, Iterable, Iterator
from typing import Final

import msgspec
from oimi.pipeline.events import BodyState, Level, LogEntries, WorldState
from oimi.recorder.scene import ObstacleGeometry, SceneGeometry
from oimi.recorder.topics import FoxgloveTopic

WORLD_FRAME: Final = "world"
ROBOT_FRAME: Final = "robot"
HUMAN_FRAME: Final = "human/{}"
"""A person's frame (and the id of the entity drawn in it), by the person's id."""
OBJECT_FRAME: Final = "object/{}"
WALL_THICKNESS_M: Final = 0.05
WALL_HEIGHT_M: Final = 0.4
OBSTACLE_HEIGHT_M: Final = 0.5
ROBOT_HEIGHT_M: Final = 0.5
HUMAN_HEIGHT_M: Final = 1.2
DEFAULT_RADIUS_M: Final = 0.2


class _Fox(msgspec.Struct, frozen=True, kw_only=True):
    """Base of the Foxglove mirrors (encoded with every field, defaults included)."""


class Time(_Fox, kw_only=True):
    sec: int
    nsec: int


class Duration(_Fox, kw_only=True):
    sec: int = 0
    nsec: int = 0


class Vector3(_Fox, kw_only=True):
    x: float
    y: float
    z: float


class Quaternion(_Fox, kw_only=True):
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0


class Pose(_Fox, kw_only=True):
    position: Vector3
    orientation: Quaternion = Quaternion()


class Color(_Fox, kw_only=True):
    r: float
    g: float
    b: float
    a: float = 1.0


class KeyValuePair(_Fox, kw_only=True):
    key: str
    value: str


class ArrowPrimitive(_Fox, kw_only=True):
    pose: Pose
    shaft_length: float
    shaft_diameter: float
    head_length: float
    head_diameter: float
    color: Color


class CubePrimitive(_Fox, kw_only=True):
    pose: Pose
    size: Vector3
    color: Color


class SpherePrimitive(_Fox, kw_only=True):
    pose: Pose
    size: Vector3
    color: Color


class CylinderPrimitive(_Fox, kw_only=True):
    pose: Pose
    size: Vector3
    bottom_scale: float = 1.0
    top_scale: float = 1.0
    color: Color


class TextPrimitive(_Fox, kw_only=True):
    pose: Pose
    billboard: bool = True
    font_size: float = 14.0
    scale_invariant: bool = True
    color: Color
    text: str


class SceneEntity(_Fox, kw_only=True):
    timestamp: Time
    frame_id: str = WORLD_FRAME
    id: str
    lifetime: Duration = Duration()
    frame_locked: bool = False
    metadata: tuple[KeyValuePair, ...] = ()
    arrows: tuple[ArrowPrimitive, ...] = ()
    cubes: tuple[CubePrimitive, ...] = ()
    spheres: tuple[SpherePrimitive, ...] = ()
    cylinders: tuple[CylinderPrimitive, ...] = ()
    lines: tuple[()] = ()
    triangles: tuple[()] = ()
    texts: tuple[TextPrimitive, ...] = ()
    models: tuple[()] = ()


_Drawing = Callable[[str, BodyState, Time], SceneEntity]
"""How a person or an object is drawn: its frame, its state, the time."""


class DeletionType(enum.IntEnum):
    MATCHING_ID = 0
    ALL = 1


class SceneEntityDeletion(_Fox, kw_only=True):
    timestamp: Time
    type: DeletionType = DeletionType.MATCHING_ID
    id: str = ""


class SceneUpdate(_Fox, kw_only=True):
    """``foxglove.SceneUpdate``."""

    deletions: tuple[SceneEntityDeletion, ...] = ()
    entities: tuple[SceneEntity, ...] = ()


class FrameTransform(_Fox, kw_only=True):
    timestamp: Time
    parent_frame_id: str
    child_frame_id: str
    translation: Vector3
    rotation: Quaternion


class FrameTransforms(_Fox, kw_only=True):
    """``foxglove.FrameTransforms``."""

    transforms: tuple[FrameTransform, ...]


class LogLevel(enum.IntEnum):
    UNKNOWN = 0
    DEBUG = 1
    INFO = 2
    WARNING = 3
    ERROR = 4
    FATAL = 5


class Log(_Fox, kw_only=True):
    """``foxglove.Log``."""

    timestamp: Time
    level: LogLevel
    message: str
    name: str
    file: str = ""
    line: int = 0


LOG_LEVELS: Final[dict[Level, LogLevel]] = {
    Level.DEBUG: LogLevel.DEBUG,
    Level.INFO: LogLevel.INFO,
    Level.WARNING: LogLevel.WARNING,
    Level.ERROR: LogLevel.ERROR,
}

LED_OFF_COLOR: Final = Color(r=0.25, g=0.25, b=0.28)
"""The LED strips' colour while the LEDs are off (unlit, dark)."""
ROBOT_BODY_COLOR: Final = Color(r=0.86, g=0.87, b=0.9)
"""The robot's body: a fixed light colour, so the robot is visible whatever its LEDs do."""
LED_STRIP_HEIGHTS_M: Final = (0.12, 0.34)
"""Heights of the centres of the robot's two LED strips, rings around its body."""
LED_STRIP_THICKNESS_M: Final = 0.05
LED_STRIP_OUTSET: Final = 1.06
"""A strip's diameter as a share of the body's (it sits proud of the body)."""
ROLE_COLORS: Final[dict[str, Color]] = {
    "child": Color(r=1.0, g=0.6, b=0.1),
    "therapist": Color(r=0.2, g=0.45, b=0.95),
}
OTHER_HUMAN_COLOR: Final = Color(r=0.6, g=0.3, b=0.8)
OBJECT_COLOR: Final = Color(r=0.2, g=0.8, b=0.3)
WALL_COLOR: Final = Color(r=0.35, g=0.35, b=0.4)
OBSTACLE_COLOR: Final = Color(r=0.5, g=0.4, b=0.3)
DOOR_COLOR: Final = Color(r=0.35, g=0.78, b=0.67)  # the door (the palette's ``door``)
HEADING_COLOR: Final = Color(r=1.0, g=1.0, b=1.0)
LABEL_COLOR: Final = Color(r=1.0, g=1.0, b=1.0)


def stamp(time_ns: int) -> Time:
    """A Foxglove time from simulated nanoseconds."""
    sec, nsec = divmod(time_ns, 1_000_000_000)
    return Time(sec=sec, nsec=nsec)


def yaw(theta_rad: float) -> Quaternion:
    """The rotation by ``theta_rad`` about z (its components rounded to 6 decimals: a
    drawing needs no more, and the file stays smaller)."""
    return _yaw(theta_rad + 0.0)  # -0.0 as 0.0: the cache must not tell them apart


@functools.lru_cache(maxsize=1024)
def _yaw(theta_rad: float) -> Quaternion:
    """:func:`yaw`, remembered: a body walking straight on keeps its heading."""
    half = theta_rad / 2.0
    return Quaternion(z=round(math.sin(half), 6), w=round(math.cos(half), 6))


def led_color(led: tuple[float, float, float]) -> Color:
    """The LED strips' colour: the LED colour, or unlit dark grey when all channels are 0."""
    if not any(led):
        return LED_OFF_COLOR
    r, g, b = led
    return Color(r=r, g=g, b=b)


def static_scene(scene: SceneGeometry, time_ns: int) -> SceneUpdate:
    """The arena's four walls, its door and the obstacles, sent once (they never change)."""
    t = stamp(time_ns)
    w, h, k = scene.width_m, scene.height_m, WALL_THICKNESS_M
    walls = (
        (w / 2, -k / 2, w + 2 * k, k),
        (w / 2, h + k / 2, w + 2 * k, k),
        (-k / 2, h / 2, k, h),
        (w + k / 2, h / 2, k, h),
    )
    cubes = tuple(
        CubePrimitive(
            pose=Pose(position=Vector3(x=x, y=y, z=WALL_HEIGHT_M / 2)),
            size=Vector3(x=sx, y=sy, z=WALL_HEIGHT_M),
            color=WALL_COLOR,
        )
        for x, y, sx, sy in walls
    )
    entities = [SceneEntity(timestamp=t, id="arena", cubes=cubes)]
    entities += [_door(scene.door, 1.5 * k, t)] if scene.door is not None else []
    entities.extend(_obstacle(obstacle, t) for obstacle in scene.obstacles)
    return SceneUpdate(entities=tuple(entities))


def _door(door: tuple[tuple[float, float], ...], across_m: float, t: Time) -> SceneEntity:
    """The door: a coloured panel over its opening in the wall, a little proud of it."""
    (x0, y0), (x1, y1) = door
    panel = CubePrimitive(
        pose=Pose(position=Vector3(x=(x0 + x1) / 2, y=(y0 + y1) / 2, z=WALL_HEIGHT_M / 2)),
        size=Vector3(x=abs(x1 - x0) or across_m, y=abs(y1 - y0) or across_m, z=WALL_HEIGHT_M),
        color=DOOR_COLOR,
    )
    return SceneEntity(timestamp=t, id="door", cubes=(panel,))


def _obstacle(obstacle: ObstacleGeometry, t: Time) -> SceneEntity:
    centre = Vector3(x=obstacle.x_m, y=obstacle.y_m, z=OBSTACLE_HEIGHT_M / 2)
    metadata = (KeyValuePair(key="kind", value=obstacle.kind),)
    if obstacle.is_disc:
        d = 2 * obstacle.radius_m
        cylinder = CylinderPrimitive(
            pose=Pose(position=centre),
            size=Vector3(x=d, y=d, z=OBSTACLE_HEIGHT_M),
            color=OBSTACLE_COLOR,
        )
        return SceneEntity(
            timestamp=t, id=f"obstacle/{obstacle.id}", metadata=metadata, cylinders=(cylinder,)
        )
    cube = CubePrimitive(
        pose=Pose(position=centre, orientation=yaw(obstacle.angle_rad)),
        size=Vector3(x=obstacle.width_m, y=obstacle.height_m, z=OBSTACLE_HEIGHT_M),
        color=OBSTACLE_COLOR,
    )
    return SceneEntity(timestamp=t, id=f"obstacle/{obstacle.id}", metadata=metadata, cubes=(cube,))


def _bodies(state: WorldState) -> Iterator[tuple[str, BodyState, _Drawing | None]]:
    """Each body of a world state with its frame and how it is drawn (the robot, drawn
    with the LEDs and the sound, by :func:`_robot`), in drawing order."""
    yield ROBOT_FRAME, state.robot, None
    for human in state.humans:
        yield HUMAN_FRAME.format(human.id), human, _human
    for thing in state.objects:
        yield OBJECT_FRAME.format(thing.id), thing, _object


def look(state: WorldState) -> tuple[object, ...]:
    """What :func:`dynamic_scene` draws of a world state apart from where the bodies are:
    the scene is sent again only when this changes."""
    return (
        state.led,
        state.audio,
        state.robot.radius_m,
        tuple([(h.id, h.kind, h.radius_m) for h in state.humans]),
        tuple([(o.id, o.radius_m) for o in state.objects]),
    )


def dynamic_scene(
    state: WorldState,
    time_ns: int,
    *,
    previous_ids: Iterable[str] = (),
    drawn: dict[tuple[str, str, float], SceneEntity] | None = None,
) -> SceneUpdate:
    """The robot, humans and objects, each drawn in its own frame (``frame_locked``: it
    moves with :func:`body_transforms`); deletes the entities of ``previous_ids`` now gone.
    ``drawn`` keeps each person's and object's entity by its frame, kind and radius, to be
    sent again as it was first drawn while those stay the same."""
    t = stamp(time_ns)
    drawn = {} if drawn is None else drawn
    entities = [_robot(state, t)]
    for frame, body, draw in _bodies(state):
        if draw is not None:
            key = (frame, body.kind, body.radius_m)
            if (entity := drawn.get(key)) is None:
                entity = drawn[key] = draw(frame, body, t)
            entities.append(entity)
    current = {entity.id for entity in entities}  # each named for the frame it is drawn in
    deletions = tuple(
        SceneEntityDeletion(timestamp=t, id=old) for old in previous_ids if old not in current
    )
    return SceneUpdate(deletions=deletions, entities=tuple(entities))


def _radius(body: BodyState) -> float:
    return body.radius_m if body.radius_m > 0 else DEFAULT_RADIUS_M


def _at(z: float) -> Pose:
    """A pose ``z`` above the origin of the entity's frame."""
    return Pose(position=Vector3(x=0.0, y=0.0, z=z))


def _robot(state: WorldState, t: Time) -> SceneEntity:
    """The body (a light cylinder), its two LED strips in the LED colour, its heading and
    name; the cylinders are the body first, then the strips from the bottom up."""
    r = _radius(state.robot)
    shell = CylinderPrimitive(
        pose=_at(ROBOT_HEIGHT_M / 2),
        size=Vector3(x=2 * r, y=2 * r, z=ROBOT_HEIGHT_M),
        color=ROBOT_BODY_COLOR,
    )
    led = led_color(state.led)
    d = 2 * r * LED_STRIP_OUTSET
    strips = tuple(
        CylinderPrimitive(pose=_at(z), size=Vector3(x=d, y=d, z=LED_STRIP_THICKNESS_M), color=led)
        for z in LED_STRIP_HEIGHTS_M
    )
    label = TextPrimitive(
        pose=_at(ROBOT_HEIGHT_M + 0.25),
        color=LABEL_COLOR,
        text=f"robot: {state.audio}" if state.audio else "robot",
    )
    arrow = ArrowPrimitive(
        pose=_at(ROBOT_HEIGHT_M + 0.05),
        shaft_length=r,
        shaft_diameter=r / 5,
        head_length=r / 2,
        head_diameter=r / 2.5,
        color=HEADING_COLOR,
    )
    metadata = (KeyValuePair(key="audio", value=state.audio),) if state.audio else ()
    return SceneEntity(
        timestamp=t,
        frame_id=ROBOT_FRAME,
        id=ROBOT_FRAME,
        frame_locked=True,
        metadata=metadata,
        cylinders=(shell, *strips),
        arrows=(arrow,),
        texts=(label,),
    )


def _human(frame: str, body: BodyState, t: Time) -> SceneEntity:
    r = _radius(body)
    cylinder = CylinderPrimitive(
        pose=_at(HUMAN_HEIGHT_M / 2),
        size=Vector3(x=2 * r, y=2 * r, z=HUMAN_HEIGHT_M),
        color=ROLE_COLORS.get(body.kind, OTHER_HUMAN_COLOR),
    )
    label = TextPrimitive(
        pose=_at(HUMAN_HEIGHT_M + 0.2),
        color=LABEL_COLOR,
        text=f"{body.id} ({body.kind})" if body.kind else body.id,
    )
    return SceneEntity(
        timestamp=t,
        frame_id=frame,
        id=frame,
        frame_locked=True,
        cylinders=(cylinder,),
        texts=(label,),
    )


def _object(frame: str, body: BodyState, t: Time) -> SceneEntity:
    r = _radius(body)
    sphere = SpherePrimitive(
        pose=_at(r), size=Vector3(x=2 * r, y=2 * r, z=2 * r), color=OBJECT_COLOR
    )
    return SceneEntity(timestamp=t, frame_id=frame, id=frame, frame_locked=True, spheres=(sphere,))


class Views:
    """Foxglove's view messages for a session's events, as the MCAP sink and the live
    server both send them: the arena (on its own topic) with the first world state; every
    ``every_n_ticks`` ticks each body's transform; the robot, people and objects, drawn in
    their frames, only when what they look like changes (each such message draws them all,
    so the last one before any time is the whole scene: Foxglove after a seek)."""

    def __init__(self, scene: SceneGeometry | None, every_n_ticks: int) -> None:
        self.scene = scene
        self.every = every_n_ticks
        self._look: tuple[object, ...] | None = None
        self._drawn: dict[tuple[str, str, float], SceneEntity] = {}
        self._static_sent = False
        self.last_scene: SceneUpdate | None = None
        """The last dynamic scene sent (a live server re-sends it to clients that join late)."""

    def world(self, state: WorldState, time_ns: int) -> list[tuple[FoxgloveTopic, _Fox]]:
        """The views due for this world state (none between thinned ticks)."""
        views: list[tuple[FoxgloveTopic, _Fox]] = []
        if not self._static_sent:
            self._static_sent = True
            if self.scene is not None:
                views.append((FoxgloveTopic.ARENA, static_scene(self.scene, time_ns)))
        elif state.tick % self.every:
            return views
        views.append((FoxgloveTopic.TF, body_transforms(state, time_ns)))
        now = look(state)
        if now != self._look:
            self._look = now
            drawn_before = self.last_scene.entities if self.last_scene is not None else ()
            self.last_scene = dynamic_scene(
                state, time_ns, previous_ids=(e.id for e in drawn_before), drawn=self._drawn
            )
            views.append((FoxgloveTopic.SCENE, self.last_scene))
        return views


def body_transforms(state: WorldState, time_ns: int) -> FrameTransforms:
    """``world -> robot``, ``world -> human/<id>``, ``world -> object/<id>``: each body's
    pose in the arena (its rotation's components rounded to 6 decimals: :func:`yaw`)."""
    t = stamp(time_ns)
    return FrameTransforms(
        transforms=tuple(
            [
                FrameTransform(
                    timestamp=t,
                    parent_frame_id=WORLD_FRAME,
                    child_frame_id=frame,
                    translation=Vector3(x=body.x_m, y=body.y_m, z=0.0),
                    rotation=yaw(body.theta_rad),
                )
                for frame, body, _ in _bodies(state)
            ]
        )
    )


def log_messages(entries: LogEntries, time_ns: int) -> list[Log]:
    """One ``foxglove.Log`` per entry; ``name`` is the speaking stage, ``ref`` joins the text."""
    t = stamp(time_ns)
    return [
        Log(
            timestamp=t,
            level=LOG_LEVELS.get(entry.level, LogLevel.UNKNOWN),
            message=f"{entry.message} [{entry.ref}]" if entry.ref else entry.message,
            name=entry.source,
        )
        for entry in entries.entries
    ]
