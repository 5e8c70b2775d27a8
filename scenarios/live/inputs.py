"""Outside input for a live session: the joystick with its dead-man guard.

The pad's states arrive whenever a client sends them (on change, plus a
heartbeat while the safety lock is held); the session takes at most one per
tick. :class:`JoystickGuard` keeps them in order, merges runs that differ only
in the sticks (so no button press is lost and no backlog builds up), and
releases the lock by itself when its owner falls silent for
:data:`HEARTBEAT_TIMEOUT_S` or disconnects: a lost link stops the robot, never
leaves it moving.
"""

from __future__ import annotations

from collections import deque
from typing import Final

import msgspec

from pipeline.events import JoystickInput

HEARTBEAT_TIMEOUT_S: Final = 0.5
"""Silence after which a held safety lock counts as released."""

LOCK: Final = "LB"


class Pad(msgspec.Struct, frozen=True, kw_only=True):
    """One state of the Xbox 360 pad, as the pipeline reads it."""

    left_x: float = 0.0
    left_y: float = 0.0
    right_x: float = 0.0
    buttons: tuple[str, ...] = ()

    @property
    def locked(self) -> bool:
        """The safety lock (dead-man, ``LB``) is held."""
        return LOCK in self.buttons

    def at(self, *, tick: int, time_ms: int) -> JoystickInput:
        """This state as the joystick input of ``tick``."""
        return JoystickInput(
            tick=tick,
            time_ms=time_ms,
            left_x=self.left_x,
            left_y=self.left_y,
            right_x=self.right_x,
            buttons=self.buttons,
        )


NEUTRAL: Final = Pad()
"""Sticks centred, nothing held: the lock released, the robot stopped."""


class JoystickGuard:
    """The pad's states in arrival order, one per tick, with the dead-man rules.

    One pad drives at a time: the latest client that sent a state owns it.
    Time (``now_s``) is the wall clock of the live session, handed in.
    """

    def __init__(self, *, timeout_s: float = HEARTBEAT_TIMEOUT_S) -> None:
        self.timeout_s = timeout_s
        self.owner: object | None = None
        self._pending: deque[Pad] = deque()
        self._applied = NEUTRAL
        self._heard_s = 0.0
        self.released: list[str] = []
        """Why the guard released the lock by itself (read and cleared by the caller)."""

    @property
    def latest(self) -> Pad:
        """The newest state, queued or applied."""
        return self._pending[-1] if self._pending else self._applied

    def receive(self, owner: object, pad: Pad, *, now_s: float) -> None:
        """A client sent the pad's state (a change, or the same as a heartbeat)."""
        self.owner = owner
        self._heard_s = now_s
        if pad == self.latest:
            return
        if self._pending and self._pending[-1].buttons == pad.buttons:
            self._pending[-1] = pad  # only the sticks moved: the newest position wins
        else:
            self._pending.append(pad)

    def lost(self, owner: object) -> None:
        """``owner`` disconnected: if it held the lock, release it."""
        if owner is self.owner:
            self.owner = None
            self._release("the joystick's client disconnected")

    def take(self, *, now_s: float) -> Pad | None:
        """The state to apply this tick, if any (after the heartbeat check)."""
        if self.latest.locked and now_s - self._heard_s > self.timeout_s:
            self._release(f"no joystick heartbeat for {self.timeout_s * 1000:.0f} ms")
        if not self._pending:
            return None
        self._applied = self._pending.popleft()
        return self._applied

    def _release(self, why: str) -> None:
        if not self.latest.locked:
            return
        self._pending.clear()
        if self._applied != NEUTRAL:
            self._pending.append(NEUTRAL)
        self.released.append(why)
