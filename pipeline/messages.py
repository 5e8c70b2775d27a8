"""Typed messages of the pipeline: the thesis's structures as ``msgspec.Struct``s.

Field names follow the thesis (sections 3.1, 4.1, 4.4, 4.5) where it gives them.
Units: speeds in m/s and rad/s, times in integer milliseconds of the simulated
clock (``_ms``), colours in [0, 1], distances in metres, angles in radians.

Schemas evolve only by appending fields with defaults, so old recordings stay
readable (see ``FORMAT_VERSION``).

Long module: it is the core's one vocabulary (docs/architecture.md: ``sense``, ``think`` and ``act``
talk only through it): scripts, updates and the world map with its tables, side by side.
"""

from __future__ import annotations

import enum
from typing import Final, NamedTuple

import msgspec

FORMAT_VERSION: Final = 9
"""Version of the recorded message layout; bumped on any incompatible change."""

READ_FORMAT_VERSIONS: Final = (2, 3, 4, 5, 6, 7, 8, 9)
"""The versions a recording may have to be read (2 wrote a ``/map`` delta's changed rows
whole, and 2 to 4 its changed ``scriptinfo`` and ``robotstatus``, which read as changes of
every field; 2 and 3 kept ``/world/state`` at every tick, 4 samples it:
``recorder.world_sampling``, 2 to 4 at micrometres; 2 to 5 have no sonar ``scantime``, the
ring's heartbeat, without which the supervisor takes a ring for down; 2 to 6 report the
robot's ``speed`` at an instant, ``startingtime`` when it was measured, where 7 reports its
mean over ``duration`` from ``startingtime``, the interval the supervisor compares with
its dead reckoning; 2 to 7 have no camera ``frametime``, the camera's heartbeat, without
which the supervisor takes a camera for offline; 2 to 8 write a ``/map`` delta's changed
row with the fields that repeat the reading its register just added, which 9 leaves out);
replays need ``FORMAT_VERSION``."""

GENERATED_SOURCE: Final = "generator:"
"""How ``ScriptInfo.script_vect`` names a generated script: ``generator:NAME``, the name of
the selected activity that generated it (a script file is named by its path)."""
REGISTER_CAPACITY: Final = 16
"""Default capacity of an appendable (circular) register in the map."""


class Message(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Base of every immutable message that crosses a stage."""


class State(msgspec.Struct, forbid_unknown_fields=True, kw_only=True):
    """Base of the mutable map structures (owned by the Map Producer and the rules)."""


class Reading(State, frozen=True):
    """Base of a register's entry (a pose, a touch, an LED colour shown ...): what was
    observed at one time, never changed once in the map (a register changes by entries
    added and dropped), so a copy of the map may share the entries, not the lists."""


# --------------------------------------------------------------------------- codes


class RuleAction(enum.IntEnum):
    """What an alfa/omega message does to a rule (encoded as the letter's code point)."""

    A = ord("A")
    """Activate the rule and add it to the active ones."""
    R = ord("R")
    """Remove the rule."""
    D = ord("D")
    """Activate the rule but hold it (delayed) for future use."""
    B = ord("B")
    """Bring a held (delayed) rule back among the active ones."""
    C = ord("C")
    """Recover a removed rule and put it among the active ones."""


class MutexCmd(enum.IntEnum):
    """When the map may propagate while the chain changes (letter's code point)."""

    L = ord("L")
    """Lock the map's propagation, then issue this message."""
    M = ord("M")
    """Issue this message."""
    U = ord("U")
    """Issue this message, then unlock the map's propagation."""


class Policy(enum.StrEnum):
    """How a MapUpdate joins the not-yet-processed updates of the same target."""

    R = "R"
    """Replace: drop every earlier pending update of the same target and attribute."""
    A = "A"
    """Append: keep the earlier pending updates and add this one."""


# ------------------------------------------------------------------------ scripts


class Channel(enum.StrEnum):
    """An instruction block's channels, in the order their commands are issued within a tick."""

    MOVE = "move"
    LED = "led"
    AUDIO = "audio"


class Move(Message):
    """One timed move: body-frame speeds held for ``duration`` after ``wait_t``."""

    v_x: float
    """Speed along the robot's x axis, m/s."""
    v_y: float
    """Speed along the robot's y axis, m/s."""
    v_theta: float
    """Angular speed, rad/s."""
    wait_t: int
    """Milliseconds to wait before acting."""
    duration: int
    """Milliseconds to act."""


class Led(Message):
    """One timed LED command."""

    r: float
    """Red, 0 to 1."""
    g: float
    """Green, 0 to 1."""
    b: float
    """Blue, 0 to 1."""
    turnas: int
    """1 turns the LEDs on, 0 off."""
    wait_t: int
    """Milliseconds to wait before acting."""
    duration: int
    """Milliseconds to act."""


class AudioOut(Message):
    """One timed audio track."""

    track_path: str
    """Path (or name) of the track to play."""
    wait_t: int
    """Milliseconds to wait before playing."""
    duration: int
    """Milliseconds to play."""


class Source(enum.StrEnum):
    """Who issued an actuator command."""

    SCRIPT = "script"
    JOYSTICK = "joystick"
    SAFETY = "safety"


class ChannelCommand(Message, tag_field="channel"):
    """Base of a command sent to one channel of the robot, tagged by its ``channel``."""

    source: Source
    stop: bool = False
    """An explicit stop after an item (stop moving, lights off, stop the track)."""

    @property
    def channel(self) -> Channel:
        """The command's tag: the channel it drives."""
        return Channel(self.__struct_config__.tag)


class MoveCommand(ChannelCommand, tag=Channel.MOVE.value):
    """A body-frame velocity for the base (zero with ``stop``)."""

    v_x: float = 0.0
    v_y: float = 0.0
    v_theta: float = 0.0
    clamped: bool = False
    """The script asked beyond the robot's limits: the speeds were clamped."""
    requested: tuple[float, float, float] | None = None
    """``(v_x, v_y, v_theta)`` the script asked for, when clamped."""


class LedCommand(ChannelCommand, tag=Channel.LED.value):
    """A colour for the LEDs (off with ``stop``)."""

    r: float = 0.0
    g: float = 0.0
    b: float = 0.0
    clamped: bool = False
    """The script asked a colour outside [0, 1]: it was clamped."""
    requested: tuple[float, float, float] | None = None
    """``(r, g, b)`` the script asked for, when clamped."""


class AudioCommand(ChannelCommand, tag=Channel.AUDIO.value):
    """A track to play (or, with ``stop``, the track stopped)."""

    track_path: str = ""


ActuatorCommand = MoveCommand | LedCommand | AudioCommand
"""One command sent to the robot: the :data:`CHANNELS` rows' commands, in their order."""


class InstructionBlock(Message, tag="instruction", tag_field="type"):
    """What the actuators do: three channels run in parallel, each a sequence of items."""

    move: tuple[Move, ...] = ()
    led: tuple[Led, ...] = ()
    audioout: tuple[AudioOut, ...] = ()
    flagged: str | None = None
    """Kept as found: the thesis shows it without explaining it."""

    def channel_items(self) -> dict[Channel, ChannelItems]:
        """Each channel's items, in :data:`CHANNELS` order."""
        return {spec.channel: getattr(self, spec.field) for spec in CHANNELS}


ChannelItems = tuple[Move, ...] | tuple[Led, ...] | tuple[AudioOut, ...]


class ChannelSpec(NamedTuple):
    """One actuator channel (one row of :data:`CHANNELS`)."""

    channel: Channel
    """Its name; also the noun its items are called by in errors (``a move``)."""
    field: str
    """The :class:`InstructionBlock` field holding its items (and their JSON key)."""
    item: type[Move] | type[Led] | type[AudioOut]
    dsl: str
    """The keyword of its item list in the script DSL (``MV(...)``)."""
    command: type[MoveCommand] | type[LedCommand] | type[AudioCommand]
    """The :data:`ActuatorCommand` the actuator issues on it (tagged by ``channel``)."""

    def item_fields(self) -> tuple[tuple[str, type], ...]:
        """The item Struct's fields and their types (``float``, ``int`` or ``str``), in
        order: the values of a DSL item and the keys of a JSON item."""
        return tuple((f.name, f.type) for f in msgspec.structs.fields(self.item))


CHANNELS: Final = (
    ChannelSpec(Channel.MOVE, "move", Move, "MV", MoveCommand),
    ChannelSpec(Channel.LED, "led", Led, "LD", LedCommand),
    ChannelSpec(Channel.AUDIO, "audioout", AudioOut, "AO", AudioCommand),
)
"""The channel registry: each actuator channel, its block field, its item Struct, its
DSL keyword and its command, in the order their commands are issued within a tick. The
actuator, the script validation, the JSON script format, the DSL (grammar and compiler)
and its renderer read it; :data:`ActuatorCommand` is the union of its commands."""


class JumpBlock(Message, tag="jump", tag_field="type"):
    """Evaluates a rule-grammar condition and goes to ``truejump`` or ``falsejump``."""

    toparse: str
    """The condition, in the rule grammar of section 4.3."""
    truejump: str = ""
    """Target ``goalX/actY/blkZ`` when true; empty: the next block."""
    falsejump: str = ""
    """Target ``goalX/actY/blkZ`` when false; empty: the next block."""


class TerminusBlock(Message, tag="terminus", tag_field="type"):
    """Ends the current script wherever it is."""


class SensorBlock(Message, tag="sensor", tag_field="type"):
    """A stub for sensor interaction: emits a sensor request and moves on."""

    request: str = ""
    """Free text handed to the sensors (the thesis leaves it to be defined)."""


Block = InstructionBlock | JumpBlock | TerminusBlock | SensorBlock


class Action(Message):
    """A subset of blocks sharing one aim; blocks are keyed ``blk0``, ``blk1``... in order."""

    blocks: tuple[Block, ...] = ()


class Goal(Message):
    """A milestone of the activity; actions are keyed ``act0``, ``act1``... in order."""

    goalid: str
    actions: tuple[Action, ...] = ()


class GeneratorNote(Message):
    """A rule's message to a script generator (thesis 3.2): words for it to hear, or
    ``quiesce`` to set it back to quiescence (the operator's button shows Get Ready)."""

    generator: str
    """The addressed generator's name (as selected by the operator)."""
    rule: str
    """The id of the rule that wrote it."""
    text: str = ""
    quiesce: bool = False


class RuleMessage(Message):
    """An alfa/omega message: loads, removes, holds or recovers a rule in the chain."""

    rulecode: int
    """Code of the rule class in the rule registry."""
    id: str
    """Name given to the rule instance."""
    intopic: str
    outtopic: str
    action: RuleAction
    mutexcmd: MutexCmd


class Script(Message):
    """An activity: goals > actions > blocks, with the rule messages sent on load/unload."""

    activityname: str
    alfarulemessages: tuple[RuleMessage, ...] = ()
    omegarulemessages: tuple[RuleMessage, ...] = ()
    goals: tuple[Goal, ...] = ()


# ---------------------------------------------------------------------- updates


class MapUpdate(Message):
    """A sensor's update of the map (section 4.5, tables 4.1 and 4.2)."""

    objectid: str
    """``CLASS/ID`` (``RobotStatus`` and ``Script`` may omit the ID)."""
    attributename: str
    policy: Policy
    jsonmsg: str
    """The content, as the tables give it (JSON text or a bare value)."""
    seq: int = 0
    """The update's id, unique within a session, named in rejections."""


# ---------------------------------------------------------------------- the map


class Pose(Reading):
    positionrho: float
    """Distance from the robot, m."""
    positiontheta: float
    """Bearing from the robot's heading, rad (counter-clockwise positive)."""
    positionchangetime: int
    """Simulated time of the observation, ms."""


class Tracking(Reading):
    permanencetime: int
    """How long the entity has been tracked, ms."""
    appearanceon: int
    """Simulated time it appeared, ms."""


class Entity(State):
    """A human, obstacle or object: fixed id and creation time, updateable pose."""

    id: str
    """Fixed: the entity's unique id within its class."""
    creationtime: int
    """Fixed: when the entity was allocated, ms (older wins rule ties)."""
    positionrho: float = 0.0
    positiontheta: float = 0.0
    positionchangetime: int = 0
    permanencetime: int = 0
    appearanceon: int = 0
    poses: list[Pose] = []
    """Appendable: the last poses (circular register)."""
    tracking: list[Tracking] = []
    """Appendable: the last tracking reports (circular register)."""
    attributes: dict[str, str] = {}
    """Free attributes (``$ID`` in rules), set by rules or generators."""


class Human(Entity):
    pass


class Obstacle(Entity):
    isfixed: bool = True


class Object(Entity):
    istarget: bool = False
    category: str = ""


class Camera(State):
    id: str
    isonline: bool = False
    width: int = 0
    height: int = 0
    fps: int = 0


class Sonar(State):
    id: str
    isonline: bool = False
    scanfrequency: int = 0


class TouchType(enum.StrEnum):
    """The touch classes of the thesis's RobotStatus ``touch`` (table 4.1)."""

    C = "C"
    """Caress."""
    H = "H"
    """Hug."""
    P = "P"
    """Push."""
    S = "S"
    """Slap."""
    T = "T"
    """Tap."""


class Touch(Reading):
    touchtype: TouchType
    """One letter: ``C`` caress, ``H`` hug, ``P`` push, ``S`` slap, ``T`` tap."""
    duration: int
    startingtime: int


class LedStatus(Reading):
    r: float
    g: float
    b: float
    frequency: int
    duration: int
    startingtime: int


class AudioStatus(Reading):
    duration: int
    startingtime: int
    trackpath: str


class SpeedStatus(Reading):
    xspeed: float
    yspeed: float
    thetaspeed: float
    duration: int
    startingtime: int


class GoalEvent(Reading):
    goalid: str
    timestamp: int


class GoalStatus(enum.StrEnum):
    """Progress of one goal of an activity."""

    PENDING = "pending"
    ACTIVE = "active"
    REACHED = "reached"
    FAILED = "failed"
    INTERRUPTED = "interrupted"


class GoalTracking(State):
    goalid: str
    status: GoalStatus = GoalStatus.PENDING
    changetime: int = 0


class ActivityStatus(enum.StrEnum):
    """Where an activity (script) known to the map is in its life."""

    LOADED = "loaded"
    RUNNING = "running"
    COMPLETED = "completed"
    INTERRUPTED = "interrupted"


class ActivityTracking(State):
    """An activity (script) known to the map, with its goals' progress."""

    activityname: str
    creationtime: int = 0
    status: ActivityStatus = ActivityStatus.LOADED
    goals: list[GoalTracking] = []


class RobotStatus(State):
    batterytimeleft: int = 0
    """Battery time left, ms."""
    elapsedtime: int = 0
    """Time since the session started, ms."""
    startingtime: int = 0
    touch: list[Touch] = []
    led: list[LedStatus] = []
    audioout: list[AudioStatus] = []
    audioin: list[str] = []
    speed: list[SpeedStatus] = []
    goalreached: list[GoalEvent] = []
    goalfailed: list[GoalEvent] = []
    goalinterrupted: list[GoalEvent] = []
    activities: list[ActivityTracking] = []
    joystick_engaged: bool = False
    """True while the operator holds the joystick's safety lock (set by the loop)."""
    joystick_engagedtime: int = 0
    """When the operator last engaged the joystick's safety lock, ms."""
    setfields: list[str] = []
    """The fields of tables 4.1/4.2 ever given a value (by an update, or the Block Reader for
    the goal registers), in the order first set. A field not listed is *unknown*: its value
    above is only a default, and a condition on it is false."""

    def mark_set(self, name: str) -> None:
        """Record that the field ``name`` has been given a value."""
        if name not in self.setfields:
            self.setfields.append(name)

    def known(self, name: str) -> bool:
        """Whether the field ``name`` was ever given a value."""
        return name in self.setfields


class ScriptInfo(State):
    """The script being executed and the block the actuators are given."""

    currentactivity: str = ""
    """Name of the running activity (``idle_activity`` when idle)."""
    scriptpath: str = ""
    """Where the running script came from (file path or generator name)."""
    goalid: str = ""
    """Key of the current goal, ``goalN``."""
    actionid: str = ""
    """Key of the current action, ``actN``."""
    blockid: str = ""
    """Key of the current block, ``blkN``."""
    goalname: str = ""
    """The current goal's own ``goalid`` text."""
    block: InstructionBlock | None = None
    """The instruction block sent to the actuators; rules may alter it."""
    changed: bool = False
    """Set when ``block`` was altered: the actuator restarts it from the beginning."""
    overridecmd: bool = False
    """Set by a rule to force a switch to ``currentactivity`` at goal/action/block."""
    restart: bool = False
    """Set by a ``script_vect`` update asking to restart: the reader drops the current script."""
    submove: int = 0
    """Index of the move item being executed."""
    subled: int = 0
    """Index of the LED item being executed."""
    subaout: int = 0
    """Index of the audio item being executed."""
    script_vect: list[str] = []
    """The LIFO of scripts waiting (last = top): each a script file's path, or
    ``generator:NAME`` (:data:`GENERATED_SOURCE`) for a selected activity's generated script."""


class WorldMap(State):
    """The map (section 4.1) that the producer fills and the rules read and change."""

    scriptinfo: ScriptInfo = msgspec.field(default_factory=ScriptInfo)
    lastupdatetime: int = 0
    """Last time the map was updated, ms."""
    robotstatus: RobotStatus = msgspec.field(default_factory=RobotStatus)
    cameras: list[Camera] = []
    sonars: list[Sonar] = []
    humans: list[Human] = []
    obstacles: list[Obstacle] = []
    objects: list[Object] = []
    variables: dict[str, str] = {}
    """Rule variables (``@ID``) of scope U, by name."""
    aliases: dict[str, str] = {}
    """Rule aliases of scope U (``?ID`` -> ``Class/id``), kept across ticks."""


class MapList(NamedTuple):
    """A class the map keeps as a list of Structs with ids (one row of :data:`MAP_LISTS`)."""

    name: str
    """The class as an update's ``objectid`` and a condition's ``#CLASS`` spell it."""
    field: str
    """The :class:`WorldMap` field holding the list."""
    struct: type[Camera] | type[Sonar] | type[Entity]
    """The Struct the producer allocates for a new id."""
    entity: bool
    """An :class:`Entity` (poses, tracking; seen by conditions) rather than a device."""


MAP_LISTS: Final = (
    MapList("Camera", "cameras", Camera, entity=False),
    MapList("Sonar", "sonars", Sonar, entity=False),
    MapList("Human", "humans", Human, entity=True),
    MapList("Obstacle", "obstacles", Obstacle, entity=True),
    MapList("Object", "objects", Object, entity=True),
)
"""The one table of the map's listed classes: the update decoder, the producer, the
invariants and the condition compiler read it (a new entity class is a row here, its
Struct and its :class:`WorldMap` field, and its attribute table in ``sense/updates.py``)."""

ENTITY_LISTS: Final = tuple(m for m in MAP_LISTS if m.entity)
"""The rows that are entities: ``Human``, ``Obstacle``, ``Object``."""

ACTIVITY_CLASS: Final = "Activity"
"""The condition language's class for the map's activities (``robotstatus.activities``)."""


# --------------------------------------------------------------- actuator outputs


class ActuatorOutputs(Message):
    """What the actuator asks of the robot's body right now (the world applies it)."""

    v_x: float = 0.0
    """Body-frame forward speed, m/s (already within the robot's limits)."""
    v_y: float = 0.0
    """Body-frame leftward speed, m/s."""
    v_theta: float = 0.0
    """Angular speed, rad/s, counter-clockwise positive."""
    led: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """LED colour, each 0 to 1; all 0 is off."""
    audio: str = ""
    """Track being played; empty is silence."""
    brake: bool = False
    """Brake to this velocity at once, beyond the comfort ramp (the base sheds its speed at
    its own braking rate: the simulated one at ``max_accel_mps2``): a protective stop (the
    safety lock released, or the safety supervisor cut the velocity). Never faster than
    the velocity it replaces."""
