"""Run many scenarios × parameter grids × seeds on a process pool or Ray; tabulate the results.

Writes one recording per run under ``--out`` (``NAME.mcap``), then
``results.parquet``, ``results.csv``, ``junit.xml`` and ``summary.txt``.
Exit 0 when every run meets its expectations, 1 when one does not, 2 on bad input.
``--replay DIR`` re-checks every recording of a folder (redrive) instead.
"""

from __future__ import annotations

import argparse
import contextlib
import shlex
import sys
import time
from collections.abc import Iterator, Sequence
from pathlib import Path

import msgspec
import polars as pl

from oimi import console
from oimi.analysis.compare import group_runs
from oimi.analysis.dataset import build_dataset
from oimi.analysis.report import write_comparison_report
from oimi.batch import results
from oimi.batch.executors import Executor, ProcessPool, RayExecutor, default_workers
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
from oimi.batch.tasks import ResultRow, finished_row, run_task
from oimi.cmd_check import add_outside_paths_argument
from oimi.extension_args import extensions_of
from oimi.paths import check_output
from oimi.recorder.errors import RecordingError
from oimi.replay.redrive import redrive

SUMMARY = "summary.txt"
JUNIT = "junit.xml"
REPLAY_RESULTS = "replay.csv"
REPORT = "report"
"""The comparison page's folder inside ``--out`` (``report/index.html``)."""
GROUP_COLUMNS = (
    "scenario",
    "params",
    "runs",
    "pass rate",
    "contacts mean",
    "robot_initiated_contacts mean",
    "min_surface_distance_m mean",
    "min_surface_distance_m min",
    "max_speed_mps mean",
)
"""What the printed comparison shows (``report/groups.csv`` holds every aggregate)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "inputs",
        nargs="*",
        type=Path,
        metavar="SPEC_OR_SCENARIOS",
        help="batch spec files, scenario files (.toml) or folders of scenario files",
    )
    parser.add_argument("--out", type=Path, default=Path("out/batch"), help="output folder")
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scenario field (dotted path); repeat a key to vary it over values",
    )
    seeds = parser.add_mutually_exclusive_group()
    seeds.add_argument("--seeds", type=int, metavar="N", help="N seeds from the scenario's own")
    seeds.add_argument("--seed-range", metavar="A:B", help="seeds A to B-1")
    parser.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help=f"parallel runs (default: cores, {default_workers()})",
    )
    parser.add_argument("--ray", action="store_true", help="run on Ray (a local instance)")
    parser.add_argument("--ray-address", metavar="ADDR", help="run on this Ray cluster")
    parser.add_argument("--resume", action="store_true", help="skip runs already finished in --out")
    add_outside_paths_argument(parser)
    parser.add_argument("--replay", type=Path, metavar="DIR", help="redrive every recording in DIR")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    if args.replay is not None:
        return run_replay(args)
    if not args.inputs:
        raise SpecError("give batch spec files, scenario files or folders", source="oimi batch")
    out_dir = check_output(args.out, folder=True).resolve()
    tasks = collect_tasks(args, out_dir)
    done: dict[int, ResultRow] = {}
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
                for position, row in executor.map(run_task, [tasks[i] for i in todo]):
                    done[todo[position]] = row
                    progress.finished(row)
    except KeyboardInterrupt:
        progress.close()
        print(
            f"interrupted after {len(done)} of {len(tasks)} runs; every finished run is kept in"
            f" {args.out}: run the same command with --resume to finish the batch",
            file=sys.stderr,
        )
        return 130
    progress.close()
    rows = [done[index] for index in range(len(tasks))]
    return report(rows, out_dir)


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


def report(rows: Sequence[ResultRow], out_dir: Path) -> int:
    """Write the table, JUnit and summary; print the summary; 1 if any run failed."""
    written = results.write_results(results.results_frame(rows), out_dir)
    junit = out_dir / JUNIT
    console.write_junit(junit, [(row.task.name, row.result) for row in rows])
    text = results.summary_text(rows)
    (out_dir / SUMMARY).write_text(text + "\n", encoding="utf-8")
    print(text)
    index = write_comparison(rows, out_dir / REPORT)
    print("results: " + ", ".join(str(p) for p in [*written, junit]))
    if index is not None:
        print(f"comparison: {index}")
    return 0 if all(row.ok for row in rows) else 1


def write_comparison(rows: Sequence[ResultRow], folder: Path) -> Path | None:
    """The comparison page of the batch's recordings (``oimi analyse``'s, verdicts from the
    runs themselves); prints its groups of scenario × parameters. None without recordings."""
    recorded = {Path(row.task.out_dir) / row.recording: row for row in rows if row.recording}
    if not recorded:
        return None

    def verdicts(path: Path) -> list[tuple[str, bool, str]]:
        return [(v.name, v.ok, v.detail) for v in recorded[path].result.verdicts]

    dataset = build_dataset(list(recorded), verdicts=verdicts)
    index = write_comparison_report(dataset.comparison, folder, links={})
    groups = group_runs(dataset.comparison)
    with console.table_config(rows=60, width_chars=200):
        print(groups.select(c for c in GROUP_COLUMNS if c in groups.columns))
    return index


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


# --------------------------------------------------------------------- replay


class ReplayRow(msgspec.Struct, frozen=True, kw_only=True):
    """One recording re-checked: whether the replay matched, and the first divergence."""

    recording: str
    ok: bool
    ticks: int
    """Ticks replayed (0 when the recording could not be replayed)."""
    detail: str


def replay_recording(path: str) -> ReplayRow:
    """Redrive one recording (a top-level function, so pool and Ray workers can run it)."""
    name = Path(path).name
    try:
        comparison = redrive(path)
    except RecordingError as error:
        return ReplayRow(recording=name, ok=False, ticks=0, detail=str(error))
    d = comparison.divergence
    detail = "identical" if d is None else f"{d.kind} {d.topic} at tick {d.tick}: {d.path}"
    return ReplayRow(recording=name, ok=comparison.ok, ticks=comparison.ticks, detail=detail)


def run_replay(args: argparse.Namespace) -> int:
    """Redrive every ``*.mcap`` of a folder on the same executors; 1 if any diverges."""
    folder: Path = args.replay
    out_dir = check_output(args.out, folder=True)
    paths = sorted(folder.glob("*.mcap"))
    if not paths:
        raise SpecError("no recordings (*.mcap) in this folder", source=str(folder))
    rows: dict[int, ReplayRow] = {}
    with executor_for(args) as executor:
        for index, row in executor.map(replay_recording, [str(p) for p in paths]):
            rows[index] = row
            if not args.quiet:
                print(f"{'ok' if row.ok else 'DIVERGED'} {row.recording}", file=sys.stderr)
    ordered = [rows[i] for i in range(len(paths))]
    out_dir.mkdir(parents=True, exist_ok=True)
    table = out_dir / REPLAY_RESULTS
    pl.DataFrame([msgspec.structs.asdict(row) for row in ordered]).write_csv(table)
    failing = [row for row in ordered if not row.ok]
    print(
        f"replay: {len(ordered)} recordings, {len(ordered) - len(failing)} identical,"
        f" {len(failing)} diverged"
    )
    for row in failing:
        print(f"DIVERGED {row.recording}: {row.detail}")
        print(f"  reproduce: {shlex.join(['oimi', 'replay', str(folder / row.recording)])}")
    print(f"results: {table}")
    return 1 if failing else 0
