"""Terminal helpers for the CLI: a progress bar, wall-clock pacing, JUnit XML."""

from __future__ import annotations

import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING
from xml.etree import ElementTree

from oimi.scenarios.schema import Scenario
from oimi.scenarios.session.runner import RunResult

if TYPE_CHECKING:
    import polars as pl


class _Line:
    """A status line on stderr: on a terminal redrawn in place, elsewhere printed."""

    def __init__(self, label: str, stream=None) -> None:
        self.label = label
        self.stream = stream or sys.stderr
        self.live = self.stream.isatty()

    def bar(self, done: int, total: int) -> str:
        return f"{self.label} [{'#' * (done * 30 // max(total, 1)):<30}]"

    def show(self, line: str) -> None:
        self.stream.write(f"\r{line}\033[K" if self.live else line + "\n")
        self.stream.flush()

    def close(self) -> None:
        if self.live:
            self.stream.write("\n")
            self.stream.flush()


class Progress(_Line):
    """A one-line progress bar on stderr: simulated time, share done and speed-up.

    On a terminal it redraws in place; elsewhere (CI logs) it prints a line per quarter.
    """

    def __init__(self, label: str, tick_ms: int, *, stream=None) -> None:
        super().__init__(label, stream)
        self.tick_ms = tick_ms
        self.start = time.perf_counter()
        self.shown = -1

    @classmethod
    def of(cls, scenario: Scenario) -> Progress:
        """The bar of a run of ``scenario`` (its name and tick)."""
        return cls(scenario.name, scenario.tick_ms)

    def __call__(self, tick: int, total: int) -> None:
        step = 200 if self.live else 4
        share = tick * step // max(total, 1)
        if share == self.shown and tick != total:
            return
        self.shown = share
        elapsed = max(time.perf_counter() - self.start, 1e-9)
        simulated = tick * self.tick_ms / 1000
        self.show(
            f"{self.bar(tick, total)} {tick * 100 // max(total, 1):3d}% "
            f"{simulated:7.1f} s simulated, {simulated / elapsed:6.0f}x real time"
        )


class Count(_Line):
    """Items done of a total on stderr (``analyse [####   ] 3/10 sessions  (NAME)``): on a
    terminal redrawn in place, elsewhere a line per item."""

    def __init__(self, label: str, noun: str, *, stream=None) -> None:
        super().__init__(label, stream)
        self.noun = noun

    def __call__(self, done: int, total: int, name: str) -> None:
        self.show(f"{self.bar(done, total)} {done}/{total} {self.noun}  ({name})")


class Pacer:
    """Sleeps so that tick ``n`` ends no earlier than ``n * tick_ms`` after the start."""

    def __init__(self, tick_ms: int) -> None:
        self.tick_s = tick_ms / 1000
        self.start = time.monotonic()

    def __call__(self, tick: int) -> None:
        delay = self.start + (tick + 1) * self.tick_s - time.monotonic()
        if delay > 0:
            time.sleep(delay)


def write_junit(
    path: Path,
    results: Sequence[tuple[str, RunResult]],
    *,
    reproduce: Mapping[str, str] | None = None,
    crashed: Mapping[str, str] | None = None,
    seconds: Mapping[str, float] | None = None,
) -> None:
    """One test suite per scenario, one test case per expectation. ``seconds`` (by suite
    name) is the wall-clock time of a run, which a CI shows as durations: the suite's
    ``time``, shared evenly among its test cases (the expectations are checked together at
    the end of the run), so that the cases add up to the suite; a suite without it (a run
    an earlier batch finished) has no ``time``. A failure's text ends
    with how to run it again (``reproduce``, by suite name); a run that crashed
    (``crashed``: its traceback, by suite name) has its failing verdict as an ``error``,
    as a CI tells a broken test from a failed one; a suite's ``system-err`` holds
    the session's errors (a rule, function or generator that failed), which a CI shows
    even when every expectation passed."""
    suites = ElementTree.Element("testsuites")
    for name, result in results:
        trace = (crashed or {}).get(name)
        failed = sum(not v.ok for v in result.verdicts)
        errors, failures = (failed, 0) if trace else (0, failed)
        suite = ElementTree.SubElement(
            suites,
            "testsuite",
            name=name,
            tests=str(len(result.verdicts)),
            failures=str(failures),
            errors=str(errors),
        )
        took = (seconds or {}).get(name)
        share = {} if took is None else {"time": f"{took / max(len(result.verdicts), 1):.3f}"}
        if took is not None:
            suite.set("time", f"{took:.3f}")
        again = (reproduce or {}).get(name)
        for verdict in result.verdicts:
            case = ElementTree.SubElement(
                suite, "testcase", classname=name, name=verdict.name, **share
            )
            if not verdict.ok:
                text = (trace or verdict.detail) + (f"\nreproduce: {again}" if again else "")
                kind = "error" if trace else "failure"
                ElementTree.SubElement(case, kind, message=verdict.detail).text = text
        if result.summary.errors:
            ElementTree.SubElement(suite, "system-err").text = "\n".join(
                f"ERROR at {error}" for error in result.summary.errors
            )
    path.parent.mkdir(parents=True, exist_ok=True)
    ElementTree.ElementTree(suites).write(path, encoding="utf-8", xml_declaration=True)


def table_config(*, rows: int = 40, width_chars: int = 240) -> pl.Config:
    """How a command prints a polars table: Markdown, every column, no dtypes or shape."""
    import polars as pl  # here: the commands that print no table start without polars

    return pl.Config(
        tbl_rows=rows,
        tbl_cols=-1,
        tbl_width_chars=width_chars,
        tbl_hide_dataframe_shape=True,
        tbl_hide_column_data_types=True,
        tbl_formatting="ASCII_MARKDOWN",
        float_precision=3,
        fmt_str_lengths=60,
    )
