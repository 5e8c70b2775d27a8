"""The watchdog on ticks: a user's code that does not return is stopped with ``Overrun``
(past an ``except Exception`` of its own), one that returns in time never is, a late tick
is told once, oimi's own code is never interrupted, and the signal handler there was
before comes back."""

from __future__ import annotations

import json
import signal
import sys
import threading
import time

import pytest
from oimi.pipeline.errors import Overrun, failure
from oimi.scenarios.session.watchdog import SIGNAL, _in_user_code, watching

PERIOD_S = 0.1
BOUND_S = 5.0
"""No loop here runs longer than this, whatever happens."""


def spin(swallow: bool = False) -> int:
    """A user's loop that does not end (bounded, so that a broken watchdog fails the test)."""
    start, n = time.monotonic(), 0
    while time.monotonic() - start < BOUND_S:
        try:
            n += len(json.dumps([n]))  # library code inside the loop
        except Exception:  # what a user may write
            if not swallow:
                raise
            continue
    return n


def test_a_loop_that_does_not_end_is_stopped_between_one_and_two_periods() -> None:
    with watching(PERIOD_S) as dog:
        start = time.monotonic()
        with pytest.raises(Overrun):
            spin()
        took = time.monotonic() - start
    assert PERIOD_S * 0.9 <= took < 2 * PERIOD_S + 0.5
    assert dog.stopped == 1


def test_the_users_own_except_exception_does_not_keep_it_going() -> None:
    with watching(PERIOD_S), pytest.raises(Overrun):
        spin(swallow=True)


def test_ticks_that_end_in_time_are_never_stopped() -> None:
    with watching(PERIOD_S) as dog:
        for _ in range(40):  # 40 ticks of 20 ms: four times the period in all
            start = time.monotonic()
            while time.monotonic() - start < 0.02:
                pass
            dog.feed()
    assert dog.stopped == 0 and dog.fed == 40


def test_a_late_tick_is_told_once_before_it_is_stopped() -> None:
    told: list[float] = []
    with watching(PERIOD_S * 3, on_late=lambda: told.append(time.monotonic()), late_s=0.05):
        start = time.monotonic()
        with pytest.raises(Overrun):
            spin()
        took = time.monotonic() - start
    assert len(told) == 1, "once per late tick"
    assert 0.05 <= told[0] - start < took


def test_ticks_in_time_are_never_late() -> None:
    told: list[float] = []
    with watching(PERIOD_S, on_late=lambda: told.append(time.monotonic()), late_s=0.15) as dog:
        for _ in range(40):  # ticks of 10 ms: 0.4 s in all
            start = time.monotonic()
            while time.monotonic() - start < 0.01:
                pass
            dog.feed()
    assert told == []


def test_a_second_stuck_call_in_the_same_tick_is_stopped_too() -> None:
    with watching(PERIOD_S) as dog:
        for _ in range(2):
            with pytest.raises(Overrun):
                spin()
    assert dog.stopped == 2


def defined(module: str, filename: str, source: str, **names: object):
    """The function ``source`` defines, as if module ``module`` in ``filename`` had it."""
    scope = {"__name__": module, "sys": sys, **names}
    exec(compile(source, filename, "exec"), scope)
    return scope["f"]


GRAB = "def f():\n    return sys._getframe()\n"
CALL = "def f():\n    return g()\n"


def test_oimis_own_code_is_not_interrupted() -> None:
    library = defined("json.fake", json.__file__, GRAB)
    in_oimi = defined("oimi.pipeline.fake", "/x/pipeline/fake.py", CALL, g=library)
    in_users = defined("my_rules", "/home/me/my_rules.py", CALL, g=library)
    assert not _in_user_code(defined("oimi.pipeline.fake", "/x/pipeline/fake.py", GRAB)())
    assert not _in_user_code(in_oimi())  # a library called by oimi
    assert _in_user_code(in_users())  # a library called by a user's code
    assert _in_user_code(defined("my_rules", "/home/me/my_rules.py", GRAB)())


def test_an_installed_extension_is_a_users_code_though_it_lives_with_the_libraries() -> None:
    installed = defined("labext.rules", json.__file__.replace("json", "labext"), GRAB)
    called = defined("oimi.pipeline.fake", "/x/pipeline/fake.py", CALL, g=installed)
    assert not _in_user_code(called()), "a library called by oimi"
    assert _in_user_code(called(), frozenset({"labext"})), "an installed extension"


def test_outside_the_main_thread_it_only_counts() -> None:
    outcome: list[object] = []

    def worker() -> None:
        with watching(PERIOD_S) as dog:
            start = time.monotonic()
            while time.monotonic() - start < 3 * PERIOD_S:
                pass
            dog.feed()
            outcome.append(dog.fed)

    thread = threading.Thread(target=worker)
    thread.start()
    thread.join(timeout=BOUND_S)
    assert outcome == [1]


def test_the_previous_handler_comes_back_and_gets_real_signals() -> None:
    got: list[int] = []

    def mine(signum: int, frame: object) -> None:
        got.append(signum)

    previous = signal.signal(SIGNAL, mine)
    try:
        with watching(PERIOD_S):
            assert signal.getsignal(SIGNAL) is not mine
            signal.raise_signal(SIGNAL)  # a real one, not the watchdog's
        assert got == [SIGNAL]
        assert signal.getsignal(SIGNAL) is mine
    finally:
        signal.signal(SIGNAL, previous)


def outer() -> None:
    inner()


def inner() -> None:
    raise Overrun


def test_an_overrun_is_placed_at_the_function_called_by_its_def_line() -> None:
    try:
        outer()
    except Overrun as error:  # as a guard of the pipeline: the frame here is not the user's
        text = failure(error.with_traceback(error.__traceback__.tb_next))
    line = outer.__code__.co_firstlineno
    assert text == f"Overrun: did not return in time (in outer, test_watchdog.py:{line})"
