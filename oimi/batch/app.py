"""A batch run (``oimi batch``): collect the tasks, run them on a pool or Ray, write the
results table, JUnit, summary and comparison page into the output folder.

``run_batch`` reports its progress on stderr while it runs and returns what is left to
print: a ``BatchReport``, or ``Interrupted`` when Ctrl-C stopped it (every finished run
is kept, so ``--resume`` finishes the batch).
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import NamedTuple

import polars as pl

from oimi import console
from oimi.analysis.compare import group_runs
from oimi.analysis.dataset import build_dataset
from oimi.analysis.report import write_comparison_report
from oimi.batch import results
from oimi.batch.executors import Executor, ProcessPool, RayExecutor
from oimi.batch.spec import (
    SpecError,
    Task,
    check_unique,
    expand,
    expand_spec,
    is_batch_spec,
    load_spec,
    parse_param,
    parse_seed_range,
    scenario_files,
)
from oimi.batch.tasks import ResultRow, finished_row, timed_task
from oimi.cmd_check import report_warnings
from oimi.extension_args import extensions_of
from oimi.recorder.outputs import check_output
from oimi.scenarios.errors import ScenarioError

SUMMARY = "summary.txt"
JUNIT = "junit.xml"
REPORT = "report"
"""The comparison page's folder inside ``--out`` (``report/index.html``)."""


class BatchReport(NamedTuple):
    """A finished batch: its rows in task order, and the files written."""

    rows: Sequence[ResultRow]
    summary: str
    files: list[Path]
    """The results tables and the JUnit file."""
    groups: pl.DataFrame | None
    """The comparison's groups of scenario × parameters (None without recordings)."""
    comparison: Path | None
    """The comparison page (None without recordings)."""

    @property
    def ok(self) -> bool:
        return all(row.ok for row in self.rows)


class Interrupted(NamedTuple):
    """A batch stopped by Ctrl-C after ``finished`` of its ``total`` runs."""

    finished: int
    total: int


def run_batch(args: argparse.Namespace) -> BatchReport | Interrupted:
    """Run the batch ``oimi batch``'s arguments name (``--resume`` skips the runs already
    finished in ``--out``); bad input raises before anything runs."""
    if not args.inputs:
        raise SpecError("give batch spec files, scenario files or folders", source="oimi batch")
    out_dir = check_output(args.out, folder=True).resolve()
    tasks = collect_tasks(args, out_dir)
    done: dict[int, ResultRow] = {}
    seconds: dict[str, float] = {}  # the runs of this batch (not the resumed ones)
    if args.resume:
        for index, task in enumerate(tasks):
            if (row := finished_row(task)) is not None:
                done[index] = row
    todo = [index for index in range(len(tasks)) if index not in done]
    out_dir.mkdir(parents=True, exist_ok=True)
    if done:
        print(f"resuming: {len(done)} of {len(tasks)} runs already finished", file=sys.stderr)
    progress = BatchProgress(total=len(tasks), quiet=args.quiet)
    for row in done.values():
        progress.skipped(row)
    try:
        if todo:
            with executor_for(args) as executor:
                for position, (row, took) in executor.map(timed_task, [tasks[i] for i in todo]):
                    done[todo[position]] = row
                    seconds[row.task.name] = took
                    progress.finished(row)
    except KeyboardInterrupt:
        progress.close()
        return Interrupted(finished=len(done), total=len(tasks))
    progress.close()
    return write_report([done[index] for index in range(len(tasks))], out_dir, seconds=seconds)


def collect_tasks(args: argparse.Namespace, out_dir: Path) -> list[Task]:
    """Every task the inputs and options name, in order; bad input fails here."""
    params: dict[str, list[str]] = {}
    for item in args.param:
        key, value = parse_param(item)
        params.setdefault(key, []).append(value)
    seed_range = parse_seed_range(args.seed_range) if args.seed_range else None
    if args.seeds is not None and args.seeds < 1:
        raise SpecError(f"--seeds must be at least 1, got {args.seeds}", source="<command line>")
    tasks: list[Task] = []
    scenarios: list[Path] = []
    said: set[str] = set()

    def warn(warning: ScenarioError) -> None:  # once each, however many runs it concerns
        if str(warning) not in said:
            said.add(str(warning))
            report_warnings([warning])

    for path in args.inputs:
        if path.is_file() and is_batch_spec(path):
            tasks += expand_spec(
                load_spec(path),
                source=path,
                out_dir=out_dir,
                params=params,
                seeds=args.seeds,
                seed_range=seed_range,
                allow_outside_paths=args.allow_outside_paths,
                extensions=extensions_of(args),
                world_every_n_ticks=args.world_every,
                warn=warn,
            )
        else:
            scenarios += scenario_files([path], base=Path.cwd())
    if scenarios:
        tasks += expand(
            scenarios,
            params=params,
            seeds=args.seeds,
            seed_range=seed_range,
            out_dir=out_dir,
            allow_outside_paths=args.allow_outside_paths,
            extensions=extensions_of(args),
            world_every_n_ticks=args.world_every,
            warn=warn,
        )
    check_unique(tasks)
    return tasks


@contextlib.contextmanager
def executor_for(args: argparse.Namespace) -> Iterator[Executor]:
    """The process pool, or Ray when ``--ray`` / ``--ray-address`` is given; closed after."""
    executor: Executor
    if args.ray or args.ray_address:
        executor = RayExecutor(address=args.ray_address, workers=args.workers)
    else:
        executor = ProcessPool(workers=args.workers)
    try:
        yield executor
    finally:
        executor.close()


def write_report(
    rows: Sequence[ResultRow], out_dir: Path, *, seconds: Mapping[str, float] | None = None
) -> BatchReport:
    """Write the table, JUnit, summary and comparison page of a finished batch; ``seconds``
    (by run name) are the JUnit file's durations."""
    written = results.write_results(results.results_frame(rows), out_dir)
    junit = out_dir / JUNIT
    console.write_junit(
        junit,
        [(row.task.name, row.result) for row in rows],
        reproduce={row.task.name: results.reproduce_command(row) for row in rows if not row.ok},
        crashed={row.task.name: row.error for row in rows if row.error},
        seconds=seconds,
    )
    text = results.summary_text(rows)
    (out_dir / SUMMARY).write_text(text + "\n", encoding="utf-8")
    comparison = write_comparison(rows, out_dir / REPORT)
    return BatchReport(
        rows=rows,
        summary=text,
        files=[*written, junit],
        groups=None if comparison is None else comparison[1],
        comparison=None if comparison is None else comparison[0],
    )


def write_comparison(rows: Sequence[ResultRow], folder: Path) -> tuple[Path, pl.DataFrame] | None:
    """The comparison page of the batch's recordings (``oimi analyse``'s, verdicts from the
    runs themselves) and its groups of scenario × parameters; None without recordings."""
    recorded = {Path(row.task.out_dir) / row.recording: row for row in rows if row.recording}
    if not recorded:
        return None

    def verdicts(path: Path) -> list[tuple[str, bool, str]]:
        return [(v.name, v.ok, v.detail) for v in recorded[path].result.verdicts]

    dataset = build_dataset(list(recorded), verdicts=verdicts)
    index = write_comparison_report(dataset.comparison, folder, links={})
    return index, group_runs(dataset.comparison)


class BatchProgress:
    """Runs done, failures and ETA on stderr; redrawn in place on a terminal, a line per run
    elsewhere."""

    def __init__(self, *, total: int, quiet: bool = False, stream=None) -> None:
        self.total = total
        self.stream = stream or sys.stderr
        self.quiet = quiet
        self.live = self.stream.isatty()
        self.start = time.monotonic()
        self.done = self.failed = self.ran = 0

    def skipped(self, row: ResultRow) -> None:
        self.done += 1
        self.failed += not row.ok

    def finished(self, row: ResultRow) -> None:
        self.done += 1
        self.ran += 1
        self.failed += not row.ok
        if self.quiet:
            return
        elapsed = time.monotonic() - self.start
        left = (self.total - self.done) * elapsed / self.ran
        bar = "#" * (self.done * 30 // max(self.total, 1))
        line = (
            f"batch [{bar:<30}] {self.done}/{self.total} runs, {self.failed} failed, "
            f"ETA {int(left) // 60}:{int(left) % 60:02d}"
        )
        if not self.live:
            line += f"  ({'ok' if row.ok else 'FAIL'} {row.task.name})"
        self.stream.write("\r" + line if self.live else line + "\n")
        self.stream.flush()

    def close(self) -> None:
        if self.live and not self.quiet:
            self.stream.write("\n")
            self.stream.flush()
