"""The timeline of one channel (move, LED or audio) of an instruction block.

A channel is a sequence of items; item ``i`` waits ``wait_t`` ms, acts for
``duration`` ms, then gets its explicit stop, and item ``i + 1`` starts at that
stop. All times are block-local integer milliseconds, computed from the items'
own numbers (never from the ticks at which earlier events happened), so a
channel never drifts.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from typing import NamedTuple, Protocol

from oimi.pipeline.messages import CHANNELS, Channel

__all__ = ["CHANNEL_ORDER", "Channel", "ChannelCursor", "Due", "Phase", "Timed", "schedule"]


CHANNEL_ORDER: tuple[Channel, ...] = tuple(spec.channel for spec in CHANNELS)
"""The stable order of channels in a tick's commands."""


class Phase(enum.StrEnum):
    """What happens to an item at a due time."""

    ACT = "act"
    """The item's command is issued (after its ``wait_t``)."""
    STOP = "stop"
    """The item's explicit stop is issued (after its ``duration``)."""


class Timed(Protocol):
    """An item of a channel: ``Move``, ``Led`` or ``AudioOut``."""

    @property
    def wait_t(self) -> int: ...

    @property
    def duration(self) -> int: ...


class Due(NamedTuple):
    """One event of a channel: at block time ``at_ms``, ``phase`` of item ``item``."""

    at_ms: int
    item: int
    phase: Phase


def schedule(items: Sequence[Timed]) -> tuple[Due, ...]:
    """Every event of a channel in time order (negative times count as 0)."""
    events: list[Due] = []
    start_ms = 0
    for i, item in enumerate(items):
        act_ms = start_ms + max(0, item.wait_t)
        stop_ms = act_ms + max(0, item.duration)
        events.append(Due(act_ms, i, Phase.ACT))
        events.append(Due(stop_ms, i, Phase.STOP))
        start_ms = stop_ms
    return tuple(events)


class ChannelCursor:
    """Walks a channel's schedule as the block's clock advances."""

    def __init__(self, items: Sequence[Timed]):
        self._events = schedule(items)
        self._count = len(items)
        self._next = 0

    def due(self, block_ms: int) -> bool:
        """An event not taken yet is due at or before ``block_ms``."""
        events = self._events
        return self._next < len(events) and events[self._next].at_ms <= block_ms

    def take_due(self, block_ms: int) -> list[Due]:
        """The events due at or before ``block_ms`` not taken yet, in order."""
        taken: list[Due] = []
        while self._next < len(self._events) and self._events[self._next].at_ms <= block_ms:
            taken.append(self._events[self._next])
            self._next += 1
        return taken

    @property
    def done(self) -> bool:
        """Every item has had its stop (an empty channel is done at once)."""
        return self._next >= len(self._events)

    @property
    def next_ms(self) -> float:
        """When its next event falls due, block time, ms (inf once done)."""
        return math.inf if self.done else self._events[self._next].at_ms

    @property
    def index(self) -> int:
        """The item being executed (waiting or acting); the item count once done."""
        return self._count if self.done else self._events[self._next].item
