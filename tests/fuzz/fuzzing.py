"""What the fuzz tests share: scaled example counts, an in-process CLI call that cannot
hang, and the property every outcome must have."""

from __future__ import annotations

import contextlib
import io
import os
import signal
import sys
from collections.abc import Iterator, Sequence
from types import FrameType

from hypothesis import HealthCheck, settings

from oimi.cli import main

HANG_S = 30
"""A call still running after this long is a hang (a generous bound: the calls take
well under a second; it only turns a hang into a failure)."""


def examples(count: int) -> int:
    """``count`` scaled by ``OIMI_FUZZ_EXAMPLES`` (a factor, 1 by default)."""
    factor = float(os.environ.get("OIMI_FUZZ_EXAMPLES", "1") or 1)
    return max(1, round(count * factor))


def fuzz_settings(count: int, *, suppress: Sequence[HealthCheck] = ()) -> settings:
    """``examples(count)`` examples, no per-example deadline; deterministic (the same
    examples at every run) unless ``OIMI_FUZZ_SEED`` is set, when pytest's
    ``--hypothesis-seed`` chooses them (``make fuzz SEED=N`` explores new ground)."""
    return settings(
        max_examples=examples(count),
        derandomize=not os.environ.get("OIMI_FUZZ_SEED"),
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, *suppress],
    )


class Hang(Exception):
    """A call ran past ``HANG_S``."""


@contextlib.contextmanager
def no_hang(what: str) -> Iterator[None]:
    def expire(signum: int, frame: FrameType | None) -> None:
        raise Hang(f"{what} still running after {HANG_S} s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.alarm(HANG_S)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def run_cli(argv: Sequence[str]) -> tuple[int, str, str]:
    """``oimi ARGV`` in this process: exit code, stdout, stderr. An exception escaping
    ``main`` (what would be a traceback) fails the test."""
    out, err = io.StringIO(), io.StringIO()
    with (
        no_hang("oimi " + " ".join(argv)),
        contextlib.redirect_stdout(out),
        contextlib.redirect_stderr(err),
    ):
        code = main(list(argv))
    return code, out.getvalue(), err.getvalue()


def assert_clean_outcome(code: int, err: str, *, located: str) -> None:
    """Exit 0, 1 or 2; on 2 the message starts with the place (``located``, a path or
    ``<condition N>``) it is about; never a traceback. A failure is also printed to stderr:
    Hypothesis can report a failing example as ``FlakyStrategyDefinition`` instead of its
    error (seen with FUZZ=100), and pytest then still shows it under "Captured stderr"."""
    if code not in (0, 1, 2):
        problem = f"exit {code}: {err}"
    elif "Traceback" in err:
        problem = f"a traceback: {err}"
    elif code == 2 and not err.startswith(located):
        problem = f"exit 2 not located at {located!r}: {err}"
    else:
        return
    print(f"fuzz failure: {problem}", file=sys.stderr)
    raise AssertionError(problem)
