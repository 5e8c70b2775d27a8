"""The pad's safety lock (dead-man, ``LB``): whether it is held and, when let go, why.

One piece of code for a scripted pad (a scenario's ``joystick`` events, in
``scenarios.session.runner``) and a live one (``oimi.live.inputs.JoystickGuard``).
Deterministic: the caller hands in the time. A live pad's client sends a heartbeat
while it holds the lock, so silence longer than ``timeout_s`` releases it; a scripted
pad sends none and has no timeout.
"""

from __future__ import annotations

from typing import Final

from oimi.pipeline.events import LockRelease, Pad

NEUTRAL: Final = Pad()
"""Sticks centred, nothing held: the lock released, the robot stopped."""


class SafetyLock:
    """The pad's latest state and when it was heard, with the three ways to let go of the
    lock (:class:`~pipeline.events.LockRelease`). Each method returns the release it
    causes, or None."""

    def __init__(self, *, timeout_s: float | None = None) -> None:
        self.timeout_s = timeout_s
        """Silence after which a held lock counts as released; None: never."""
        self.pad = NEUTRAL
        """The newest state (neutral after a heartbeat timeout or a disconnection)."""
        self._heard_s = 0.0

    @property
    def held(self) -> bool:
        """The newest state holds the lock."""
        return self.pad.locked

    def receive(self, pad: Pad, *, now_s: float) -> LockRelease | None:
        """A state of the pad (a change, or the same as a heartbeat): ``OPERATOR`` when it
        lets go of the lock the last state held."""
        before, self.pad, self._heard_s = self.pad, pad, now_s
        return LockRelease.OPERATOR if before.locked and not pad.locked else None

    def lost(self) -> LockRelease | None:
        """The pad's client disconnected: ``DISCONNECTED`` if it held the lock (the pad
        goes neutral)."""
        if not self.pad.locked:
            return None
        self.pad = NEUTRAL
        return LockRelease.DISCONNECTED

    def expire(self, *, now_s: float) -> LockRelease | None:
        """``HEARTBEAT`` when the lock is held and nothing was heard for longer than
        ``timeout_s`` (the pad goes neutral)."""
        if self.timeout_s is None or not self.pad.locked:
            return None
        if now_s - self._heard_s <= self.timeout_s:
            return None
        self.pad = NEUTRAL
        return LockRelease.HEARTBEAT
