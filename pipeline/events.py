"""What the pipeline emits: one Struct per recorded topic, one message per topic per tick.

Every event carries ``tick`` (the simulated clock's tick count) and ``time_ms``
(simulated milliseconds); a tick's items are batched into one message so the
recorder writes at most one message per topic per tick.
"""

from __future__ import annotations

import enum
from typing import Any, ClassVar, Final, Generic, TypeVar, get_args, get_origin

import msgspec
from oimi.pipeline.messages import (
    MAP_LISTS,
    ActuatorCommand,
    InstructionBlock,
    MapUpdate,
    Message,
    RobotStatus,
    RuleMessage,
    ScriptInfo,
    State,
)
from oimi.pipeline.messages import Source as Source  # re-exported with the commands
from oimi.pipeline.operator.commands import OperatorCommand


class Topic(enum.StrEnum):
    """The recorded topics (docs/recording.md lists them)."""

    SENSOR_UPDATES = "/sensors/updates"
    OPERATOR_COMMANDS = "/operator/commands"
    OPERATOR_STATE = "/operator/state"
    JOYSTICK = "/joystick"
    MAP = "/map"
    RULE_DECISIONS = "/rules/decisions"
    RULE_CHAIN = "/rules/chain"
    READER_PROGRESS = "/reader/progress"
    ACTUATOR_COMMANDS = "/actuator/commands"
    WORLD_STATE = "/world/state"
    LOG = "/log"
    SAFETY = "/safety"


INPUT_TOPICS: Final = (Topic.SENSOR_UPDATES, Topic.OPERATOR_COMMANDS, Topic.JOYSTICK)
"""Topics that carry what came from outside the robot's mind (replayed by redrive)."""


class Event(Message):
    """Base of a topic's per-tick message."""

    tick: int
    time_ms: int


# ------------------------------------------------------------------------- inputs


class SensorUpdates(Event):
    """Every MapUpdate that arrived this tick, in arrival order."""

    updates: tuple[MapUpdate, ...]


class OperatorCommands(Event):
    """The operator's commands applied this tick, in arrival order (numbered by the session)."""

    commands: tuple[OperatorCommand, ...]


class LockRelease(enum.StrEnum):
    """Why the joystick's safety lock was released (``JoystickInput.release``)."""

    OPERATOR = "operator"
    """The operator let go of the lock."""
    HEARTBEAT = "heartbeat"
    """The pad's client fell silent while holding the lock (no heartbeat)."""
    DISCONNECTED = "disconnected"
    """The pad's client disconnected while holding the lock."""


class Button(enum.StrEnum):
    """The pad's buttons, as ``JoystickInput.buttons`` names them."""

    LB = "LB"
    """Left bumper: the safety lock, held while the operator drives."""
    RB = "RB"
    """Right bumper: blocking mode (with the lock)."""
    A = "A"
    """Unbound."""
    B = "B"
    """Unbound."""
    X = "X"
    """Interrupt block execution (with the lock)."""
    Y = "Y"
    """Unbound."""
    BACK = "BACK"
    """Unbound."""
    START = "START"
    """Unbound."""


class Pad(Message):
    """One state of the pad (Xbox 360 layout, see ``pipeline.act.joystick``): the one shape
    every layer uses. The scenario file's ``joystick`` event and the live ``joystick``
    request carry the same fields and give theirs with ``.pad``; a tick's recorded
    :class:`JoystickInput` is ``pad.at(...)`` and gives it back with ``.pad``."""

    left_x: float = 0.0
    """Left stick, right positive, -1 to 1."""
    left_y: float = 0.0
    """Left stick, forward positive, -1 to 1."""
    right_x: float = 0.0
    """Right stick, right positive, -1 to 1."""
    buttons: tuple[Button, ...] = ()
    """Buttons held."""

    @property
    def locked(self) -> bool:
        """The safety lock (dead-man, ``LB``) is held."""
        return Button.LB in self.buttons

    def at(self, *, tick: int, time_ms: int, release: LockRelease | None = None) -> JoystickInput:
        """This state as the joystick input of ``tick``."""
        return JoystickInput(
            tick=tick,
            time_ms=time_ms,
            left_x=self.left_x,
            left_y=self.left_y,
            right_x=self.right_x,
            buttons=self.buttons,
            release=release,
        )


class JoystickInput(Event):
    """The pad's state when it changed, at a tick (recorded flat: :class:`Pad`'s fields)."""

    left_x: float = 0.0
    """Left stick, right positive, -1 to 1."""
    left_y: float = 0.0
    """Left stick, forward positive, -1 to 1."""
    right_x: float = 0.0
    """Right stick, right positive, -1 to 1."""
    buttons: tuple[Button, ...] = ()
    """Buttons held."""
    release: LockRelease | None = None
    """Set on the input that releases a held lock, saying why (None: not a release, or a
    scenario's scripted pad)."""

    @property
    def pad(self) -> Pad:
        """The pad's state without its tick."""
        return Pad(
            left_x=self.left_x, left_y=self.left_y, right_x=self.right_x, buttons=self.buttons
        )


# ------------------------------------------------------------------------ outputs


_ABSENT: Final = msgspec.Raw()


_Reading = TypeVar("_Reading")


class Appended(
    msgspec.Struct, Generic[_Reading], forbid_unknown_fields=True, kw_only=True, omit_defaults=True
):
    """A register's change in a ``/map`` delta: the ``dropped`` oldest readings gone, then
    ``added`` appended (a circular register that took one reading: ``dropped`` 1, one added)."""

    dropped: int = 0
    added: list[_Reading]


def _patch_of(part: type[State]) -> type[msgspec.Struct]:
    """The type of a row's or a section's change in a delta: a row's ``id`` and the fields
    that changed, a list either whole or :class:`Appended` (a whole one is a change of every
    field)."""
    keyed = "id" in part.__struct_fields__
    fields: list[tuple[str, Any] | tuple[str, Any, Any]] = [("id", str)] if keyed else []
    for field in msgspec.structs.fields(part):
        if field.name == "id":
            continue
        kind = field.type
        if get_origin(kind) is list:
            kind = kind | Appended[get_args(kind)[0]]  # type: ignore[index]
        fields.append((field.name, kind | msgspec.UnsetType, msgspec.UNSET))
    return msgspec.defstruct(
        f"{part.__name__}Patch", fields, kw_only=True, forbid_unknown_fields=True
    )


ROW_PATCHES: Final[dict[str, type[msgspec.Struct]]] = {
    m.field: _patch_of(m.struct) for m in MAP_LISTS
}
"""Each table's row change in a delta (``HumanPatch``...): fields left out are unchanged."""
SECTION_PATCHES: Final[dict[str, type[msgspec.Struct]]] = {
    "scriptinfo": _patch_of(ScriptInfo),
    "robotstatus": _patch_of(RobotStatus),
}
"""The map's Struct sections' change in a delta (format 5; whole before), as a row's."""


class MapDelta(Event, omit_defaults=True):
    """The world map after this tick's producer and rules, when it changed: a keyframe (the
    whole map) or a delta (what changed since the previous ``/map`` message).

    One Struct for both, told apart by ``keyframe``, so the topic keeps one schema: a
    keyframe has every section and row, whole; a delta only the sections that changed (an
    empty ``Raw``, left out of the JSON: unchanged; ``scriptinfo`` and ``robotstatus`` as a
    :data:`SECTION_PATCHES` change, the others whole), the rows that appeared (whole) or
    changed (a :data:`ROW_PATCHES` row: the id and only the fields that changed; a register
    that took readings as :class:`Appended`, without the row's fields that repeat its newest
    reading: format 9), in the map's order, and, in ``removed``, the
    ``Class/id`` (``Human/ada``) of rows forgotten. A delta's row is a change when the map
    before it has the id. Keyframes come first and then at the first change
    ``PipelineConfig.map_keyframe_ms`` or more after the previous one. Parts are the JSON
    the loop encoded (``msgspec.Raw``; :data:`RAW_TYPES` says what each holds);
    ``pipeline.mapdeltas`` makes them and its ``apply_delta`` rebuilds full maps
    (``Recording.maps()`` in the reader).
    """

    keyframe: bool = False
    """The whole map: applied to nothing (every earlier message may be skipped)."""
    scriptinfo: msgspec.Raw = _ABSENT
    lastupdatetime: msgspec.Raw = _ABSENT
    robotstatus: msgspec.Raw = _ABSENT
    cameras: tuple[msgspec.Raw, ...] = ()
    sonars: tuple[msgspec.Raw, ...] = ()
    humans: tuple[msgspec.Raw, ...] = ()
    obstacles: tuple[msgspec.Raw, ...] = ()
    objects: tuple[msgspec.Raw, ...] = ()
    variables: msgspec.Raw = _ABSENT
    aliases: msgspec.Raw = _ABSENT
    removed: tuple[str, ...] = ()
    """``Class/id`` of the rows forgotten since the previous message (deltas only)."""
    RAW_TYPES: ClassVar[dict[str, object]] = {
        "scriptinfo": SECTION_PATCHES["scriptinfo"],
        "lastupdatetime": int,
        "robotstatus": SECTION_PATCHES["robotstatus"],
        **{table: tuple[patch, ...] for table, patch in ROW_PATCHES.items()},  # type: ignore[valid-type]
        "variables": dict[str, str],
        "aliases": dict[str, str],
    }
    """The type each raw field holds (as ``WorldMap``'s; a Struct section as its change and a
    table as a tuple of its rows' changes, of which a whole section or row is one)."""


class MapChange(Message):
    """One field a rule changed: ``path`` in the map, values as JSON text."""

    path: str
    old: str
    new: str


class RuleDecision(Message):
    rule: str
    """The rule instance's id (its name in the chain)."""
    rulecode: int
    fired: bool
    """The condition's result."""
    bindings: dict[str, str] = {}
    """Alias or variable -> what it was bound to (``Human/child1`` or a value)."""
    changes: tuple[MapChange, ...] = ()


class RuleDecisions(Event):
    """Every active rule's evaluation this tick, in chain order."""

    decisions: tuple[RuleDecision, ...]


class RuleChainState(Event):
    """Alfa/omega messages applied this tick and the chain after them."""

    applied: tuple[RuleMessage, ...]
    active: tuple[str, ...]
    held: tuple[str, ...]
    removed: tuple[str, ...]
    locked: bool = False


class ProgressKind(enum.StrEnum):
    LOAD = "load"
    BLOCK = "block"
    JUMP = "jump"
    TERMINUS = "terminus"
    END = "end"
    SENSOR = "sensor"
    SWITCH = "switch"
    IDLE = "idle"
    GOAL_REACHED = "goal_reached"
    GOAL_FAILED = "goal_failed"
    GOAL_INTERRUPTED = "goal_interrupted"


class ProgressItem(Message):
    kind: ProgressKind
    activity: str
    path: str = ""
    """``goalX/actY/blkZ`` where it happened."""
    detail: str = ""


class ReaderProgress(Event):
    """The block in the works and what the Block Reader did this tick."""

    activity: str
    goalid: str
    actionid: str
    blockid: str
    items: tuple[ProgressItem, ...] = ()


class ActuatorCommands(Event):
    """The commands the actuator issued this tick, in channel order, each tagged by its
    ``channel`` with that channel's fields only."""

    commands: tuple[ActuatorCommand, ...]
    block: InstructionBlock | None = None
    """The block being executed, when it started this tick."""


class MotionSource(enum.StrEnum):
    """Where the motion the safety supervisor limits came from."""

    SCRIPT = "script"
    """A block of the running script."""
    RULE = "rule"
    """A block a rule forced into the map (``scriptinfo.block`` replaced)."""
    JOYSTICK = "joystick"
    """The operator's pad, with the safety lock held."""


class SafetyZone(enum.StrEnum):
    """Why the safety supervisor limited the velocity (``pipeline.act.safety``)."""

    STOP = "stop"
    """A human inside the stop zone: no motion towards them (protective stop)."""
    SLOW = "slow"
    """A human inside the slow zone (or within braking distance of the stop zone)."""
    STALE = "stale"
    """A human's data is older than ``max_data_age_ms``: speed capped at the slow speed."""
    BLIND = "blind"
    """No camera online, or no sonar: speed capped at the slow speed; no sensor online at
    all: no linear motion."""


class SafetyPhase(enum.StrEnum):
    """Where an intervention episode is: it starts, changes zone/human/source, or ends."""

    START = "start"
    CHANGE = "change"
    END = "end"


class SafetyIntervention(Event):
    """The safety supervisor changed the commanded velocity (or stopped changing it).

    Written only when an episode starts, changes (zone, human or source) or ends,
    never every tick: ``requested`` and ``allowed`` are that tick's velocities.
    """

    phase: SafetyPhase
    source: MotionSource
    zone: SafetyZone
    """The episode's zone (at ``end``: the zone it ended in)."""
    human: str = ""
    """The human whose separation bound the velocity (``Obstacle/<id>`` for a sonar echo of a
    body that is not fixed; empty for ``blind``/``stale`` caps)."""
    surface_distance_m: float | None = None
    """That human's surface-to-surface distance as the supervisor estimated it: the map's
    centre distance, dead-reckoned, less both radii and the uncertainty margin, m."""
    requested: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """``(v_x, v_y, v_theta)`` the source asked for (after the robot's limits and ramp)."""
    allowed: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """``(v_x, v_y, v_theta)`` the supervisor let through."""


class BodyState(Message):
    id: str
    kind: str
    """``robot``, ``child``, ``therapist``, ``ball``, ``obstacle``..."""
    x_m: float
    y_m: float
    theta_rad: float = 0.0
    vx_mps: float = 0.0
    vy_mps: float = 0.0
    omega_radps: float = 0.0
    radius_m: float = 0.0


class WorldState(Event):
    robot: BodyState
    humans: tuple[BodyState, ...] = ()
    objects: tuple[BodyState, ...] = ()
    led: tuple[float, float, float] = (0.0, 0.0, 0.0)
    audio: str = ""
    contacts: tuple[str, ...] = ()
    """Ids of humans touching the robot this tick (safety events)."""


class Level(enum.IntEnum):
    DEBUG = 1
    INFO = 2
    WARNING = 3
    ERROR = 4


class LogEntry(Message):
    level: Level
    source: str
    """The stage that speaks: ``producer``, ``rules``, ``reader``, ``actuator``, ``operator``,
    ``generators``, ``safety``."""
    message: str
    ref: str = ""
    """What it is about: an update's ``seq``, a rule id, an operator command id."""


REJECTING_SOURCES: Final = ("producer", "operator", "reader", "rules")
"""Log sources whose warnings mean an input (update, command, script, rule) was rejected."""


class LogEntries(Event):
    entries: tuple[LogEntry, ...]


class OperatorReply(Message):
    id: int
    ok: bool
    reason: str = ""


class OperatorButton(enum.StrEnum):
    """The activity command button's face (thesis 5.1)."""

    GET_READY = "get_ready"
    """Some selected generator is quiescent (or nothing is selected)."""
    LOADING = "loading"
    """Inert: the scripts were just generated; ``start`` at the next tick."""
    START = "start"
    """Every selected generator has its script; nothing is running."""
    STOP = "stop"
    """The selected activities are running."""


class ActivityState(enum.StrEnum):
    """A selected activity's state (thesis 5.1)."""

    NOT_YET_COMPLETED = "not_yet_completed"
    CURRENT = "current"
    COMPLETED = "completed"
    """Not run again until ``restart``."""


class ActivityEntry(Message):
    name: str
    options: dict[str, str] = {}
    state: ActivityState = ActivityState.NOT_YET_COMPLETED


class OperatorState(Event):
    """The handler's state after this tick's commands: what a console renders."""

    button: OperatorButton
    """``get_ready``, ``loading``, ``start`` or ``stop``."""
    activities: tuple[ActivityEntry, ...] = ()
    replies: tuple[OperatorReply, ...] = ()


TOPIC_TYPES: Final[dict[Topic, type[Event]]] = {
    Topic.SENSOR_UPDATES: SensorUpdates,
    Topic.OPERATOR_COMMANDS: OperatorCommands,
    Topic.OPERATOR_STATE: OperatorState,
    Topic.JOYSTICK: JoystickInput,
    Topic.MAP: MapDelta,
    Topic.RULE_DECISIONS: RuleDecisions,
    Topic.RULE_CHAIN: RuleChainState,
    Topic.READER_PROGRESS: ReaderProgress,
    Topic.ACTUATOR_COMMANDS: ActuatorCommands,
    Topic.WORLD_STATE: WorldState,
    Topic.LOG: LogEntries,
    Topic.SAFETY: SafetyIntervention,
}
"""The payload type of every topic."""


def encode(event: Event) -> bytes:
    """The canonical JSON encoding of an event (what is recorded and compared)."""
    return msgspec.json.encode(event)
