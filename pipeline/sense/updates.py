"""The update table of the thesis (section 4.5, tables 4.1 and 4.2) and payload decoding.

A ``MapUpdate`` names a target (``CLASS/ID``), an attribute, a policy and a payload
(``jsonmsg``). This module judges everything that can be judged without the map:
the class, the ID, the attribute, the policy and the payload, which it decodes into a
typed value ready to be stored. The Map Producer (``producer``) stores it.

Payload shapes, as the tables give them:

- ``"s_true"`` / ``"s_false"``: the bare text ``s_true`` or ``s_false``;
- ``"int number"``: a bare decimal integer, e.g. ``640`` (no sign, no spaces);
- ``"string"``: the bare text, stored as is;
- JSON objects: strict JSON (the tables' trailing ``"`` is a typo and is rejected),
  decoded into the payload Structs below: unknown fields, missing fields and wrong
  types are errors; an integer is accepted where a float is expected.
"""

from __future__ import annotations

import enum
import functools
import re
from collections.abc import Callable, Mapping
from typing import Annotated, Final, Literal, TypeVar

import msgspec
from oimi.pipeline.errors import LocatedError
from oimi.pipeline.messages import (
    AudioStatus,
    GoalEvent,
    LedStatus,
    MapUpdate,
    Policy,
    Pose,
    SpeedStatus,
    Touch,
    Tracking,
)
from oimi.pipeline.sense.script_names import ID_RE, check_script_entry

INT_MAX: Final = 2**63 - 1
"""Largest integer a payload may carry (it must survive a JSON round trip as int64)."""


class MapUpdateError(LocatedError):
    """A MapUpdate that cannot be applied; the message names the target and what is wrong."""


class EntityClass(enum.StrEnum):
    """The ``CLASS`` part of an ``objectid``."""

    CAMERA = "Camera"
    SONAR = "Sonar"
    HUMAN = "Human"
    OBSTACLE = "Obstacle"
    OBJECT = "Object"
    ROBOT_STATUS = "RobotStatus"
    """The robot's single status: the ID is optional and ignored."""
    SCRIPT = "Script"
    """The map's single ScriptInfo: the ID is optional and ignored."""


SINGLETON_CLASSES: Final = frozenset({EntityClass.ROBOT_STATUS, EntityClass.SCRIPT})
"""Classes with exactly one instance in the map; their ID is optional and ignored."""


class Storage(enum.StrEnum):
    """How a field of the map keeps its values (the colours of the thesis's figure 4.1)."""

    FIXED = "fixed"
    """Set when the entity is allocated, never changed (``id``, ``creationtime``)."""
    UPDATEABLE = "updateable"
    """A new value replaces the old one."""
    APPENDABLE = "appendable"
    """Values go into a bounded circular register: every update is appended (``R`` only
    drops the pending updates issued before it)."""
    NOTED = "noted"
    """Not in the thesis's map: the producer notes the latest value for the safety
    supervisor (a sonar's ``scantime``, a camera's ``frametime``, their heartbeats:
    ``MapProducer.beats``)."""


class Target(msgspec.Struct, frozen=True, kw_only=True):
    """Where an update goes: a class and the ID inside it (empty for singletons)."""

    klass: EntityClass
    id: str = ""

    def __str__(self) -> str:
        return f"{self.klass}/{self.id}" if self.id else str(self.klass)


# ------------------------------------------------------------------ payload Structs

NonNegInt = Annotated[int, msgspec.Meta(ge=0, le=INT_MAX)]
NonNegFloat = Annotated[float, msgspec.Meta(ge=0.0)]
UnitFloat = Annotated[float, msgspec.Meta(ge=0.0, le=1.0)]
NonEmptyStr = Annotated[str, msgspec.Meta(min_length=1)]


class Payload(msgspec.Struct, frozen=True, forbid_unknown_fields=True):
    """Base of the JSON payloads of tables 4.1 and 4.2."""


class PosePayload(Payload):
    positionrho: NonNegFloat
    """Distance from the robot, m."""
    positiontheta: float
    """Bearing from the robot's heading, rad."""
    positionchangetime: NonNegInt
    """Time of the observation, ms."""


class TrackingPayload(Payload):
    permanencetime: NonNegInt
    """How long the entity has been tracked, ms."""
    appearanceon: NonNegInt
    """Time it appeared, ms."""


class TouchPayload(Payload):
    touchtype: Literal["C", "H", "P", "S", "T", "c", "h", "p", "s", "t"]
    """``C`` caress, ``H`` hug, ``P`` push, ``S`` slap, ``T`` tap (table 4.1 says ``char``:
    a lower-case letter is its upper-case type, stored upper-case)."""
    duration: NonNegInt
    startingtime: NonNegInt


class LedPayload(Payload):
    r: UnitFloat
    g: UnitFloat
    b: UnitFloat
    frequency: NonNegInt
    """Blink frequency, Hz."""
    duration: NonNegInt
    startingtime: NonNegInt


class AudioOutPayload(Payload):
    duration: NonNegInt
    startingtime: NonNegInt
    trackpath: NonEmptyStr


class SpeedPayload(Payload):
    xspeed: float
    """m/s."""
    yspeed: float
    """m/s."""
    thetaspeed: float
    """rad/s."""
    duration: NonNegInt
    startingtime: NonNegInt


class GoalEventPayload(Payload):
    goalid: NonEmptyStr
    timestamp: NonNegInt


class ScriptVectPayload(Payload):
    restart: Literal["s_true", "s_false"]
    update: list[str]
    """The LIFO of script paths, bottom first (last entry = top)."""


class ScriptVect(msgspec.Struct, frozen=True, kw_only=True):
    """A decoded ``Script/script_vect`` update."""

    restart: bool
    paths: tuple[str, ...]


# ------------------------------------------------------------------ scalar decoders

_P = TypeVar("_P", bound=Payload)
_V = TypeVar("_V")

_INT_RE: Final = re.compile(r"[0-9]+", re.ASCII)


def _decode_bool(text: str) -> bool:
    if text == "s_true":
        return True
    if text == "s_false":
        return False
    raise ValueError(f"expected 's_true' or 's_false', got {text!r}")


def _decode_int(text: str) -> int:
    if not _INT_RE.fullmatch(text):
        raise ValueError(f"expected a non-negative decimal integer, got {text!r}")
    value = int(text)
    if value > INT_MAX:
        raise ValueError(f"integer {text} is out of range (at most {INT_MAX})")
    return value


def _decode_text(text: str) -> str:
    return text


def _json_decoder(kind: type[_P], build: Callable[[_P], _V]) -> Callable[[str], _V]:
    decoder = msgspec.json.Decoder(kind)

    def decode(text: str) -> _V:
        try:
            return build(decoder.decode(text))
        except msgspec.DecodeError as exc:  # ValidationError is a subclass
            raise ValueError(str(exc)) from None

    return decode


def _pose(p: PosePayload) -> Pose:
    return Pose(
        positionrho=p.positionrho,
        positiontheta=p.positiontheta,
        positionchangetime=p.positionchangetime,
    )


def _tracking(p: TrackingPayload) -> Tracking:
    return Tracking(permanencetime=p.permanencetime, appearanceon=p.appearanceon)


def _touch(p: TouchPayload) -> Touch:
    return Touch(touchtype=p.touchtype.upper(), duration=p.duration, startingtime=p.startingtime)


def _led(p: LedPayload) -> LedStatus:
    return LedStatus(
        r=p.r,
        g=p.g,
        b=p.b,
        frequency=p.frequency,
        duration=p.duration,
        startingtime=p.startingtime,
    )


def _audioout(p: AudioOutPayload) -> AudioStatus:
    return AudioStatus(duration=p.duration, startingtime=p.startingtime, trackpath=p.trackpath)


def _speed(p: SpeedPayload) -> SpeedStatus:
    return SpeedStatus(
        xspeed=p.xspeed,
        yspeed=p.yspeed,
        thetaspeed=p.thetaspeed,
        duration=p.duration,
        startingtime=p.startingtime,
    )


def _goal_event(p: GoalEventPayload) -> GoalEvent:
    return GoalEvent(goalid=p.goalid, timestamp=p.timestamp)


def _script_vect(p: ScriptVectPayload) -> ScriptVectPayload:
    return p  # paths are checked against the script root by ``decode_update``


# ------------------------------------------------------------------ the table


class AttributeSpec(msgspec.Struct, frozen=True, kw_only=True):
    """One row of tables 4.1/4.2: attribute, allowed policies, payload, storage."""

    name: str
    policies: tuple[Policy, ...]
    payload: str
    """The payload's shape as the thesis writes it (for messages and docs)."""
    storage: Storage
    decode: Callable[[str], object]
    mirrors: tuple[str, ...] = ()
    """Fields of an appended value copied onto the owner as its current scalars."""


_R: Final = (Policy.R,)
_RA: Final = (Policy.R, Policy.A)
_BOOL: Final = '"s_true" or "s_false"'
_INT: Final = '"int number"'
_POSE: Final = (
    '{"positionrho": float number, "positiontheta": float number, "positionchangetime": int number}'
)
_TRACKING: Final = '{"permanencetime": int number, "appearanceon": int number}'
_GOAL: Final = '{"goalid": "string", "timestamp": int number}'


def _updateable(name: str, payload: str, decode: Callable[[str], object]) -> AttributeSpec:
    return AttributeSpec(
        name=name, policies=_R, payload=payload, storage=Storage.UPDATEABLE, decode=decode
    )


def _noted(name: str, payload: str, decode: Callable[[str], object]) -> AttributeSpec:
    return AttributeSpec(
        name=name, policies=_R, payload=payload, storage=Storage.NOTED, decode=decode
    )


def _appendable(
    name: str, payload: str, decode: Callable[[str], object], mirrors: tuple[str, ...] = ()
) -> AttributeSpec:
    return AttributeSpec(
        name=name,
        policies=_RA,
        payload=payload,
        storage=Storage.APPENDABLE,
        decode=decode,
        mirrors=mirrors,
    )


_POSES: Final = _appendable(
    "poses",
    _POSE,
    _json_decoder(PosePayload, _pose),
    mirrors=("positionrho", "positiontheta", "positionchangetime"),
)
_TRACKINGS: Final = _appendable(
    "tracking",
    _TRACKING,
    _json_decoder(TrackingPayload, _tracking),
    mirrors=("permanencetime", "appearanceon"),
)


def _table(*specs: AttributeSpec) -> dict[str, AttributeSpec]:
    return {spec.name: spec for spec in specs}


UPDATE_TABLE: Final[Mapping[EntityClass, Mapping[str, AttributeSpec]]] = {
    EntityClass.CAMERA: _table(
        _updateable("isonline", _BOOL, _decode_bool),
        _updateable("width", _INT, _decode_int),
        _updateable("height", _INT, _decode_int),
        _updateable("fps", _INT, _decode_int),
        _noted("frametime", _INT, _decode_int),
    ),
    EntityClass.SONAR: _table(
        _updateable("isonline", _BOOL, _decode_bool),
        _updateable("scanfrequency", _INT, _decode_int),
        _noted("scantime", _INT, _decode_int),
    ),
    EntityClass.HUMAN: _table(_POSES, _TRACKINGS),
    EntityClass.OBSTACLE: _table(_POSES, _TRACKINGS, _updateable("isfixed", _BOOL, _decode_bool)),
    EntityClass.OBJECT: _table(
        _POSES,
        _TRACKINGS,
        _updateable("istarget", _BOOL, _decode_bool),
        _updateable("category", '"string"', _decode_text),
    ),
    EntityClass.ROBOT_STATUS: _table(
        _updateable("batterytimeleft", _INT, _decode_int),
        _appendable(
            "touch",
            '{"touchtype": char, "duration": int number, "startingtime": int number}',
            _json_decoder(TouchPayload, _touch),
        ),
        _appendable(
            "led",
            '{"r": int number, "g": int number, "b": int number, "frequency": int number, '
            '"duration": int number, "startingtime": int number}',
            _json_decoder(LedPayload, _led),
        ),
        _appendable(
            "audioout",
            '{"duration": int number, "startingtime": int number, "trackpath": string}',
            _json_decoder(AudioOutPayload, _audioout),
        ),
        _appendable("audioin", '"TBD"', _decode_text),
        _appendable(
            "speed",
            '{"xspeed": float number, "yspeed": float number, "thetaspeed": float number, '
            '"duration": int number, "startingtime": int number}',
            _json_decoder(SpeedPayload, _speed),
        ),
        _updateable("elapsedtime", _INT, _decode_int),
        _appendable("goalreached", _GOAL, _json_decoder(GoalEventPayload, _goal_event)),
        _appendable("goalfailed", _GOAL, _json_decoder(GoalEventPayload, _goal_event)),
        _appendable("goalinterrupted", _GOAL, _json_decoder(GoalEventPayload, _goal_event)),
        _updateable("startingtime", _INT, _decode_int),
    ),
    EntityClass.SCRIPT: _table(
        _updateable("submove", _INT, _decode_int),
        _updateable("subled", _INT, _decode_int),
        _updateable("subaout", _INT, _decode_int),
        _updateable(
            "script_vect",
            '{"restart": "s_true" or "s_false", "update": ["string", ..., "string"]}',
            _json_decoder(ScriptVectPayload, _script_vect),
        ),
    ),
}
"""Tables 4.1 and 4.2 as implemented: class -> attribute -> row."""


# ------------------------------------------------------------------ objectid


@functools.lru_cache(maxsize=1024)  # sensors name the same few entities every tick
def parse_objectid(objectid: str) -> Target:
    """``CLASS/ID`` (or the thesis's ``CLASS\\ID``) to a Target; raises ``MapUpdateError``."""
    parts = re.split(r"[/\\]", objectid, maxsplit=1)
    name = parts[0]
    ident = parts[1] if len(parts) == 2 else None
    try:
        klass = EntityClass(name)
    except ValueError:
        known = ", ".join(EntityClass)
        raise MapUpdateError(
            f"objectid {objectid!r}: unknown class {name!r} (expected one of {known})"
        ) from None
    if klass in SINGLETON_CLASSES:
        return Target(klass=klass)  # the single instance: any ID names it
    if not ident:
        raise MapUpdateError(f"objectid {objectid!r}: class {klass} needs an ID (CLASS/ID)")
    if not ID_RE.fullmatch(ident):
        raise MapUpdateError(
            f"objectid {objectid!r}: bad ID {ident!r} (no whitespace, '/' or '\\' allowed)"
        )
    return Target(klass=klass, id=ident)


# ------------------------------------------------------------------ decoding an update


class DecodedUpdate(msgspec.Struct, frozen=True, kw_only=True):
    """An update judged valid without the map: its target, table row and decoded value."""

    update: MapUpdate
    target: Target
    spec: AttributeSpec
    value: object
    """A scalar for updateable fields; a map Struct (or str) for appendable ones;
    a ``ScriptVect`` for ``Script/script_vect``."""
    key: tuple[EntityClass, str, str]
    """What an ``R`` replaces: class, ID and attribute (taken once: the producer compares
    it with each pending update's)."""


def decode_update(update: MapUpdate, *, script_root: str = "activities") -> DecodedUpdate:
    """Judge ``update`` against tables 4.1/4.2; raises ``MapUpdateError`` naming the fault."""
    target = parse_objectid(update.objectid)
    rows = UPDATE_TABLE[target.klass]
    spec = rows.get(update.attributename)
    if spec is None:
        known = ", ".join(rows)
        raise MapUpdateError(
            f"{_where(target, update)}: unknown attribute {update.attributename!r} for class"
            f" {target.klass} (expected one of {known})"
        )
    if update.policy not in spec.policies:
        allowed = ", ".join(spec.policies)
        raise MapUpdateError(
            f"{_where(target, update)}: policy {update.policy} not allowed (allowed: {allowed})"
        )
    try:
        value = spec.decode(update.jsonmsg)
    except ValueError as exc:
        raise MapUpdateError(f"{_where(target, update)}: bad jsonmsg: {exc}") from None
    if type(value) is ScriptVectPayload:  # (isinstance would ask the Struct's metaclass)
        where = _where(target, update)
        for index, path in enumerate(value.update):
            problem = check_script_entry(path, script_root=script_root)
            if problem:
                raise MapUpdateError(f"{where}: at `$.update[{index}]`: {problem}")
        value = ScriptVect(restart=value.restart == "s_true", paths=tuple(value.update))
    key = (target.klass, target.id, spec.name)
    return DecodedUpdate(update=update, target=target, spec=spec, value=value, key=key)


def _where(target: Target, update: MapUpdate) -> str:
    """Where an update goes, as its faults are said (``Human/ada.poses``): worked out only
    for a fault (formatting the target took a fifth of a valid update's decoding)."""
    return f"{target}.{update.attributename}"
