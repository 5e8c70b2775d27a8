"""Ctrl-C (SIGINT) at safe points: between ticks, and never while a recording is finished.

Python raises ``KeyboardInterrupt`` wherever the interpreter happens to be; inside a
recorder's write that can leave the MCAP writer's statistics ahead of its chunks (a file
whose summary counts messages it does not hold). A session therefore takes Ctrl-C only
between ticks, and ignores it while its files are closed.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator
from types import FrameType


@contextlib.contextmanager
def interrupts_held() -> Iterator[None]:
    """Ignore Ctrl-C for the duration, so that a second Ctrl-C cannot cut a file short
    while it is being finished; a no-op outside the main thread."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@contextlib.contextmanager
def interrupts_between_ticks() -> Iterator[Callable[[], None]]:
    """Defer Ctrl-C to the caller's checkpoints: yields ``checkpoint()``, which raises
    ``KeyboardInterrupt`` if Ctrl-C came since the last call.

    Only Python's default handler is deferred (in the main thread): a caller that
    installed its own SIGINT handling (an event loop) keeps it, and the checkpoint
    never raises."""
    pending = False

    def checkpoint() -> None:
        nonlocal pending
        if pending:
            pending = False
            raise KeyboardInterrupt

    def defer(signum: int, frame: FrameType | None) -> None:
        nonlocal pending
        pending = True

    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGINT) is not signal.default_int_handler
    ):
        yield checkpoint
        return
    signal.signal(signal.SIGINT, defer)
    try:
        yield checkpoint
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)
