"""Which world states a recording keeps (format 4): not every tick's.

``/world/state`` at every tick was half of a busy session's file. A recording keeps the
state of every ``every_n_ticks``-th tick (25 Hz by default at 50 Hz), of **every tick on
which a person touches the robot** and of the first tick after a contact ends (so contact
episodes, their ticks and their speeds read back exactly), and the session's **last**
state, written when the recording closes (so the last tick read is the session's last).
The pipeline and the run's own checks still see every tick; the MCAP sink, the golden
digest and the closed-loop replay's comparison apply the same :class:`WorldSampling`.
"""

from __future__ import annotations

from typing import Final

from oimi.pipeline.events import WorldState
from oimi.recorder.errors import RecordingError
from oimi.recorder.metadata import OimiRecord

DEFAULT_WORLD_EVERY_N_TICKS: Final = 2
"""``/world/state`` every second tick: 25 Hz at the default 50 Hz tick rate."""
WORLD_EVERY_KEY: Final = "world_every_n_ticks"
"""The ``oimi`` metadata key that records a recording's sampling."""


class WorldSampling:
    """Decides, state by state and in tick order, which world states are kept."""

    def __init__(self, every_n_ticks: int = DEFAULT_WORLD_EVERY_N_TICKS) -> None:
        if every_n_ticks < 1:
            raise RecordingError(f"world_every_n_ticks must be >= 1, got {every_n_ticks}")
        self.every_n_ticks = every_n_ticks
        self._held: tuple[int, WorldState] | None = None
        """The last state seen and not kept, with its log time: the session's last state
        if no other follows (:meth:`last`)."""
        self._touching: tuple[str, ...] = ()

    def keep(self, time_ns: int, state: WorldState) -> bool:
        """Whether ``state`` is kept: a due tick, a contact, or the tick after one."""
        contacts, touching = state.contacts, self._touching
        self._touching = contacts
        if not state.tick % self.every_n_ticks or contacts or touching:
            self._held = None
            return True
        self._held = (time_ns, state)
        return False

    def last(self) -> tuple[int, WorldState] | None:
        """The session's last state when it was not kept (the recording writes it at its
        close), once."""
        held, self._held = self._held, None
        return held


def recorded_sampling(record: OimiRecord, *, source: str) -> WorldSampling:
    """The sampling a recording's ``oimi`` record states (every tick before format 4;
    ``RecordingError`` naming ``source``, the file, for a value that is not a positive
    integer)."""
    every = record.world_every
    if every is None:
        raise RecordingError(
            f"metadata: {WORLD_EVERY_KEY} is not a positive integer:"
            f" {record.world_every_n_ticks!r}",
            source=source,
        )
    return WorldSampling(every)
