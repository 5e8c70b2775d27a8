"""The watchdog on ticks: a user's code that holds a tick (a rule body, a function or a
generator in a loop that does not end) has :class:`~oimi.pipeline.errors.Overrun` raised
in it, so that it costs that code, not the session.

The pipeline guards every call into a user's code: a rule that raises is removed, a
generator's call refused, a jump condition taken as false, each said at ERROR on ``/log``.
What it cannot do is stop a call that never returns: the core keeps no clock and starts
no thread. The loop that ticks it (a run, a live session, a replay) feeds this watchdog
once a tick; its thread looks four times a period (or as often as a tick may be late, when
someone is to be told), and when no tick has ended for :data:`PERIOD_S`, it asks the main
thread to raise, as a signal would (:func:`_thread.interrupt_main`). The main thread
raises only while it is in a user's code (the innermost frame that is neither the
standard library's nor an installed package's, other than an installed extension, is not
oimi's); else it is asked again a period later. A stuck tick is thus stopped about a
period after it began, and a replay of the session stops it alike (a loop that changed
the map while it ran may leave a value a replay does not reproduce). Python can only be
interrupted between two of its instructions: a call into C that never returns, or code
run outside the main thread, is not stopped.

Before that, a tick that has not ended :data:`LATE_S` after the one before is *late*: the
watchdog calls ``on_late`` once, from its own thread (a live session on a robot commands it
to stand still: its control loop is not running).
"""

from __future__ import annotations

import _thread
import contextlib
import signal
import sysconfig
import threading
import time
from collections.abc import Callable, Iterator
from types import FrameType
from typing import Final

from oimi.pipeline.errors import Overrun
from oimi.scenarios.extensions import installed_extension_packages

PERIOD_S: Final = 1.0
"""A tick still running this long is stuck (a tick lasts 20 ms; a generator that needs
longer stalls the robot's control loop too)."""
LATE_S: Final = 0.2
"""A tick not ended this long after the last one is late (ten ticks at 50 Hz)."""
SIGNAL: Final = signal.SIGUSR2
"""The signal whose handler raises (simulated with ``interrupt_main``: none is sent)."""
LIBRARIES: Final = tuple(
    {sysconfig.get_paths()[key] for key in ("stdlib", "platstdlib", "purelib", "platlib")}
)
"""Where the standard library's and the installed packages' code lives."""


class Watchdog:
    """Counts the ticks that ended (:meth:`feed`) and stops one that does not end."""

    def __init__(
        self,
        period_s: float = PERIOD_S,
        *,
        on_late: Callable[[], None] | None = None,
        late_s: float = LATE_S,
    ) -> None:
        self.period_s = period_s
        self.on_late = on_late
        self.late_s = late_s
        self.fed = 0
        """Ticks ended so far."""
        self.stopped = 0
        """Overruns raised so far."""
        self._stuck: int | None = None
        """The count the watchdog saw twice in a row (the tick after it is stuck)."""
        self.asked = False
        """The main thread was asked to raise (a real signal finds this False)."""
        self._quit = threading.Event()

    def feed(self) -> None:
        """A tick ended."""
        self.fed += 1

    def _watch(self) -> None:
        seen, since, told = -1, time.monotonic(), False
        soonest = min(self.period_s, self.late_s) if self.on_late else self.period_s
        while not self._quit.wait(soonest / 4):
            fed, now = self.fed, time.monotonic()
            if fed != seen:
                seen, since, told, self._stuck = fed, now, False, None
                continue
            if self.on_late is not None and not told and now - since >= self.late_s:
                told = True
                with contextlib.suppress(Exception):  # the watch goes on whatever it does
                    self.on_late()
            if now - since >= self.period_s:
                since = now  # asked again a period later, if it does not raise now
                self._stuck, self.asked = fed, True
                _thread.interrupt_main(SIGNAL)

    def _stop(self, frame: FrameType | None) -> None:
        """In the main thread: raise in a user's code that holds a stuck tick."""
        self.asked = False
        if self._stuck != self.fed or not _in_user_code(frame, installed_extension_packages()):
            return  # the tick ended meanwhile (or none is stuck), or oimi's code is running
        self._stuck = None  # the rest of the tick is watched afresh
        self.stopped += 1
        raise Overrun


def _in_user_code(frame: FrameType | None, users: frozenset[str] = frozenset()) -> bool:
    """Whether the innermost frame that is not a library's is a user's (not oimi's); the
    packages ``users`` are a user's wherever they are installed."""
    while frame is not None:
        module = str(frame.f_globals.get("__name__", ""))
        if module == "oimi" or module.startswith("oimi."):
            return False
        if module.partition(".")[0] in users:
            return True
        filename = frame.f_code.co_filename
        if not filename.startswith(LIBRARIES) and not filename.startswith("<"):
            return True
        frame = frame.f_back
    return False


@contextlib.contextmanager
def watching(
    period_s: float = PERIOD_S,
    *,
    on_late: Callable[[], None] | None = None,
    late_s: float = LATE_S,
) -> Iterator[Watchdog]:
    """A :class:`Watchdog` on the ticks run inside the block (feed it once per tick), which
    calls ``on_late`` (from its thread) once per late tick. Outside the main thread it only
    counts: it cannot interrupt another thread."""
    dog = Watchdog(period_s, on_late=on_late, late_s=late_s)
    if threading.current_thread() is not threading.main_thread():
        yield dog
        return
    previous = signal.getsignal(SIGNAL)

    def handler(signum: int, frame: FrameType | None) -> None:
        if dog.asked:
            dog._stop(frame)
        elif callable(previous):  # a real signal, for the handler there was before
            previous(signum, frame)

    signal.signal(SIGNAL, handler)
    thread = threading.Thread(target=dog._watch, name="oimi-watchdog", daemon=True)
    thread.start()
    try:
        yield dog
    finally:
        dog._quit.set()
        thread.join()
        signal.signal(SIGNAL, previous)
