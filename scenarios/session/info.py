"""What a live session records about itself: its own id, date, pseudonym, therapist, notes.

A scripted run's recording id is fixed (``NAME-seedN``) so that a re-run writes the
same file; a live session happens once, so its id carries its start time and a random
suffix. The date and the suffix come from the caller (the edge owns the wall clock).
The ``session`` metadata record is written when the recording opens and written
again when it closes, then with the true duration and tick count.
"""

from __future__ import annotations

from datetime import datetime

import msgspec
from oimi.pipeline.events import Topic, WorldState
from oimi.recorder.metadata import SessionRecord
from oimi.scenarios.errors import ScenarioError

SESSION_RECORD = "session"
"""The metadata record holding a live session's fields."""
FIELD_LIMITS = {"child": 64, "therapist": 64, "notes": 2000}
"""Longest text accepted for each free-text field."""


class SessionInfo(msgspec.Struct, frozen=True, kw_only=True):
    """A live session's identity and the operator's fields (``oimi serve --child ...``)."""

    recording_id: str
    date: str
    """Start, ISO 8601 in UTC (``2026-11-23T18:04:05Z``)."""
    child: str = ""
    """The child's pseudonym (never a real name)."""
    therapist: str = ""
    notes: str = ""

    def record(self) -> SessionRecord:
        """The ``session`` metadata record."""
        return SessionRecord(
            recording_id=self.recording_id,
            date=self.date,
            child=self.child,
            therapist=self.therapist,
            notes=self.notes,
        )


def new_session_info(
    scenario_name: str,
    *,
    started: datetime,
    suffix: str,
    child: str = "",
    therapist: str = "",
    notes: str = "",
) -> SessionInfo:
    """A live session's info; ``started`` is an aware UTC time, ``suffix`` random text that
    makes the id unique. A field too long or holding control characters is bad input."""
    check_fields(child=child, therapist=therapist, notes=notes, flag="--")
    stamp = started.strftime("%Y%m%dT%H%M%SZ")
    return SessionInfo(
        recording_id=f"{scenario_name}-live-{stamp}-{suffix}",
        date=started.strftime("%Y-%m-%dT%H:%M:%SZ"),
        child=child,
        therapist=therapist,
        notes=notes,
    )


def check_fields(*, flag: str = "", **fields: str) -> None:
    """Refuse (:class:`ScenarioError`) a field over its :data:`FIELD_LIMITS` or holding a
    control character (notes may hold line breaks); ``flag`` prefixes the field's name."""
    source = "<command line>" if flag else "<console>"
    for name, value in fields.items():
        limit = FIELD_LIMITS[name]
        if len(value) > limit:
            raise ScenarioError(
                f"{flag}{name} is {len(value)} characters long; at most {limit}", source=source
            )
        bad = [c for c in value if not c.isprintable() and not (name == "notes" and c == "\n")]
        if bad:
            raise ScenarioError(
                f"{flag}{name} holds a control character ({bad[0]!r})", source=source
            )


def with_fields(info: SessionInfo, **fields: str | None) -> SessionInfo:
    """``info`` with the fields given (``None``: unchanged), checked by :func:`check_fields`."""
    given = {name: value for name, value in fields.items() if value is not None}
    check_fields(**given)
    return msgspec.structs.replace(info, **given)


class TickCounter:
    """A sink that counts the ticks a session ran (one world state per tick)."""

    def __init__(self, tick_ms: int) -> None:
        self.tick_ms = tick_ms
        self.ticks = 0

    def record(self, topic: Topic, time_ns: int, message: object) -> None:
        if isinstance(message, WorldState):
            self.ticks = message.tick + 1

    def elapsed(self) -> dict[str, str]:
        """``ticks`` and ``duration_s`` (ticks x tick length) as metadata strings."""
        return {"ticks": str(self.ticks), "duration_s": repr(self.ticks * self.tick_ms / 1000)}
