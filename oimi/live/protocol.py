"""The App Interface's messages: newline-delimited JSON over TCP, the same over WebSocket.

A client sends requests, one JSON object per line, tagged by ``cmd``::

    {"id": 1, "cmd": "add", "activity": "test_dance", "options": {"tempo": "fast"}}
    {"id": 2, "cmd": "get_ready"}
    {"id": 3, "cmd": "subscribe"}

and gets one :class:`Reply` per request (``ok`` true: done; false: refused, with
the reason), plus, once subscribed, a :class:`StateMessage` whenever the command
button, the activities or the current block change (and :class:`WorldMessage`
frames of the live view when asked for). Decoding is strict: unknown commands
or fields, wrong types and lines over :data:`MAX_LINE_BYTES` are refused.
"""

from __future__ import annotations

from typing import Annotated, Final

import msgspec

from oimi.pipeline.events import (
    ActivityEntry,
    BodyState,
    Button,
    LogEntry,
    Pad,
    SafetyIntervention,
)
from oimi.pipeline.operator.commands import OperatorCommand
from oimi.pipeline.operator.generator import GeneratorInfo
from oimi.recorder.scene import SceneGeometry
from oimi.scenarios.session.info import FIELD_LIMITS

MAX_LINE_BYTES: Final = 64 * 1024
"""The longest request accepted; a longer one is refused and the connection closed."""

PROTOCOL_VERSION: Final = 1


class Request(
    msgspec.Struct, frozen=True, kw_only=True, forbid_unknown_fields=True, tag_field="cmd"
):
    """Base of the session's own requests: ``id`` is the client's, echoed in the reply.

    The operator's commands (``pipeline/operator/commands.py``) are requests too, tagged
    by the same ``cmd``; the server hands them to the session as they are."""

    id: int = 0


# ----------------------------------------------------------------- session requests


class Auth(Request, tag="auth", kw_only=True):
    """The shared token, first thing on a guarded port."""

    token: str


class Subscribe(Request, tag="subscribe", kw_only=True):
    """Push state changes to this client; ``world`` adds the live view (~10 Hz)."""

    world: bool = False


class Unsubscribe(Request, tag="unsubscribe", kw_only=True):
    pass


class GetState(Request, tag="state", kw_only=True):
    """The current state, once (the reply's ``state``)."""


class Joystick(Request, tag="joystick", kw_only=True):
    """The pad's state (Xbox 360 layout); send on change and as a heartbeat while the
    safety lock (``LB``) is held. Silence for 500 ms with the lock held releases it."""

    left_x: float = 0.0
    left_y: float = 0.0
    right_x: float = 0.0
    buttons: tuple[Button, ...] = ()

    @property
    def pad(self) -> Pad:
        """The pad's state this request reports."""
        return Pad(
            left_x=self.left_x, left_y=self.left_y, right_x=self.right_x, buttons=self.buttons
        )


class SetSession(Request, tag="session", kw_only=True):
    """The session record's fields from the console (``None``: unchanged), written to the
    recording's ``session`` metadata when the session ends. At most ``FIELD_LIMITS``
    characters each, no control characters (line breaks allowed in the notes)."""

    child: Annotated[str, msgspec.Meta(max_length=FIELD_LIMITS["child"])] | None = None
    therapist: Annotated[str, msgspec.Meta(max_length=FIELD_LIMITS["therapist"])] | None = None
    notes: Annotated[str, msgspec.Meta(max_length=FIELD_LIMITS["notes"])] | None = None


AnyRequest = OperatorCommand | Auth | Subscribe | Unsubscribe | GetState | Joystick | SetSession

_decoder = msgspec.json.Decoder(AnyRequest)


class ProtocolError(ValueError):
    """A request that cannot be read; ``id`` is the request's id when it could be found."""

    def __init__(self, message: str, *, id: int | None = None) -> None:
        super().__init__(message)
        self.id = id


def decode_request(line: bytes | str) -> AnyRequest:
    """One request from one line; a :class:`ProtocolError` saying why not."""
    data = line.encode() if isinstance(line, str) else line
    if len(data) > MAX_LINE_BYTES:
        raise ProtocolError(f"message too long: {len(data)} bytes > {MAX_LINE_BYTES}")
    try:
        return _decoder.decode(data)
    except msgspec.ValidationError as error:
        raise ProtocolError(f"bad request: {error}", id=_id_of(data)) from None
    except msgspec.DecodeError as error:
        raise ProtocolError(f"malformed JSON: {error}") from None


def _id_of(data: bytes) -> int | None:
    try:
        value = msgspec.json.decode(data)
    except msgspec.DecodeError:
        return None
    if isinstance(value, dict) and type(value.get("id")) is int:
        return value["id"]
    return None


# ------------------------------------------------------------------------ to clients


class Message(msgspec.Struct, frozen=True, kw_only=True, omit_defaults=True, tag_field="type"):
    """Base of every message a client receives."""


class Block(msgspec.Struct, frozen=True, kw_only=True):
    """Where the Block Reader is: the current activity, goal, action and block."""

    activity: str = ""
    goal: str = ""
    action: str = ""
    block: str = ""


class SessionState(msgspec.Struct, frozen=True, kw_only=True):
    """What the console's activity screen shows."""

    tick: int
    time_ms: int
    button: str
    """``get_ready``, ``loading``, ``start`` or ``stop`` (the activity command button)."""
    activities: tuple[ActivityEntry, ...] = ()
    block: Block = Block()
    paused_by: str = ""
    """The script the Block Reader runs instead of the current activity, which waits in
    its LIFO (a rule's compulsory switch, e.g. to ``wait_for_child``); empty while the
    current activity runs, or none is current."""


class SessionFields(msgspec.Struct, frozen=True, kw_only=True):
    """The session record's fields as they stand (the child's pseudonym, never a name)."""

    child: str = ""
    therapist: str = ""
    notes: str = ""


class Reply(Message, tag="reply", kw_only=True):
    id: int | None
    """The request's id (``None`` when the line could not be read)."""
    ok: bool
    reason: str = ""
    tick: int | None = None
    """The tick at which an operator command was applied, or a joystick state will be."""
    catalogue: tuple[GeneratorInfo, ...] | None = None
    """For ``list``: every available activity with its options."""
    state: SessionState | None = None
    """For ``state``: the current state."""
    session: SessionFields | None = None
    """For ``session``: the fields as recorded."""


class StateMessage(Message, tag="state", kw_only=True):
    state: SessionState


class Hello(Message, tag="hello", kw_only=True):
    """First message on every connection. On a guarded port the first says only that a
    token is required; the full hello (scenario, tick, scene) follows the accepted ``auth``."""

    protocol: int = PROTOCOL_VERSION
    scenario: str = ""
    tick_ms: int = 0
    auth_required: bool = False
    scene: SceneGeometry | None = None
    """The arena and its furniture, for the live view."""
    session: SessionFields | None = None
    """The session record's fields (a live session that keeps one)."""


class WorldMessage(Message, tag="world", kw_only=True):
    """A frame of the live view: the robot in the arena."""

    tick: int
    time_ms: int
    robot: BodyState
    humans: tuple[BodyState, ...] = ()
    objects: tuple[BodyState, ...] = ()
    led: tuple[float, float, float] = (0.0, 0.0, 0.0)
    audio: str = ""
    block: Block = Block()
    fired: tuple[str, ...] = ()
    """Rules whose condition held in the last second."""
    log: tuple[LogEntry, ...] = ()
    """The latest warnings (rejected inputs, clamps, refusals), newest last."""
    joystick_engaged: bool = False
    released: str = ""
    """Why the safety lock was last released by the session (the operator let go, the
    heartbeat was lost, the client disconnected); empty while engaged or never released."""
    safety: SafetyIntervention | None = None
    """The safety supervisor's episode under way (its zone, the person it keeps away, the
    source it limits, as it started or last changed); None while it limits nothing."""


AnyMessage = Reply | StateMessage | Hello | WorldMessage

_encoder = msgspec.json.Encoder()


def encode_message(message: Message) -> bytes:
    """One message as a JSON line (with the newline)."""
    return _encoder.encode(message) + b"\n"
