"""Outside input for a live session: the joystick as a state, with its dead-man guard.

The pad's states arrive whenever a client sends them (on change, plus a
heartbeat while the safety lock is held). :class:`JoystickGuard` keeps the pad
as *state*, not a queue: each tick applies the latest state, however many came
in since the last tick, so motion can never pile up behind the present. Button
*presses* (edges) between two ticks survive: a button pressed and let go within
one tick is held for that tick. The lock is the exception: letting go of it,
falling silent for :data:`HEARTBEAT_TIMEOUT_S` or disconnecting releases it in
the next tick, drops every pending press, and the input says why
(:class:`~pipeline.events.LockRelease`, worked out by
:class:`~pipeline.act.safety_lock.SafetyLock`, as for a scripted pad).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Final

import msgspec

from oimi.pipeline.act.safety_lock import NEUTRAL, SafetyLock
from oimi.pipeline.events import Button, LockRelease, Pad

HEARTBEAT_TIMEOUT_S: Final = 0.5
"""Silence after which a held safety lock counts as released."""

LOCK: Final = Button.LB

__all__ = ["NEUTRAL", "JoystickGuard", "Pad", "Taken"]

RELEASE_TEXT: Final = {
    LockRelease.OPERATOR: "the operator let go of the lock",
    LockRelease.HEARTBEAT: f"no joystick heartbeat for {HEARTBEAT_TIMEOUT_S * 1000:.0f} ms",
    LockRelease.DISCONNECTED: "the joystick's client disconnected",
}
"""Each release reason as the console and the log say it."""


class Taken(msgspec.Struct, frozen=True, kw_only=True):
    """What the guard hands to one tick: the pad and, on a release, why."""

    pad: Pad
    release: LockRelease | None = None


class JoystickGuard:
    """The pad's latest state, taken once per tick, with the dead-man rules.

    One pad drives at a time: the latest client that sent a state owns it.
    Time (``now_s``) is the wall clock of the live session, handed in. Memory is
    constant: a state, the presses since the last tick and one release reason.
    """

    def __init__(self, *, timeout_s: float = HEARTBEAT_TIMEOUT_S) -> None:
        self.owner: object | None = None
        self._lock = SafetyLock(timeout_s=timeout_s)
        """The newest state received, and the lock's releases."""
        self._applied = NEUTRAL
        """The state the last taken input gave the pipeline."""
        self._presses: set[Button] = set()
        """Buttons (other than the lock) pressed since the last tick."""
        self._release: LockRelease | None = None
        """The lock was released since the last tick, and why."""
        self._sources: list[Callable[[float], None]] = []

    def poll(self, source: Callable[[float], None]) -> None:
        """Call ``source(now_s)`` first in every :meth:`take`: pad states that arrive another
        way than from a client (``/joy`` over DDS) count in the tick that takes them."""
        self._sources.append(source)

    @property
    def latest(self) -> Pad:
        """The newest state received."""
        return self._lock.pad

    def receive(self, owner: object, pad: Pad, *, now_s: float) -> None:
        """A client sent the pad's state (a change, or the same as a heartbeat)."""
        self.owner = owner
        before = self._lock.pad
        if released := self._lock.receive(pad, now_s=now_s):
            self._let_go(released)
        elif pad.locked:
            self._presses.update(b for b in pad.buttons if b != LOCK and b not in before.buttons)

    def lost(self, owner: object) -> None:
        """``owner`` disconnected: if it held the lock, release it."""
        if owner is self.owner:
            self.owner = None
            if released := self._lock.lost():
                self._let_go(released)

    def take(self, *, now_s: float) -> Taken | None:
        """This tick's input (after the heartbeat check); None when nothing changed."""
        for source in self._sources:
            source(now_s)
        if released := self._lock.expire(now_s=now_s):
            self._let_go(released)
        release, self._release = self._release, None
        if release is not None:
            self._presses.clear()
            if not self._applied.locked:
                release = None  # the lock never reached the robot: nothing to release
            else:
                self._applied = NEUTRAL
                return Taken(pad=NEUTRAL, release=release)
        pad = self._lock.pad
        if self._presses:
            buttons = {*pad.buttons, *self._presses}
            pad = msgspec.structs.replace(pad, buttons=tuple(sorted(buttons)))
            self._presses.clear()
        if pad == self._applied:
            return None
        self._applied = pad
        return Taken(pad=pad)

    def _let_go(self, why: LockRelease) -> None:
        if self._release is None:
            self._release = why
        self._presses.clear()
