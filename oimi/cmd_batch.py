"""Run many scenarios × parameter grids × seeds on a process pool or Ray; tabulate the results.

Writes one recording per run under ``--out`` (``NAME.mcap``), then
``results.parquet``, ``results.csv``, ``junit.xml`` and ``summary.txt``.
Exit 0 when every run meets its expectations, 1 when one does not, 2 on bad input.
``--replay DIR`` re-checks every recording of a folder (redrive) instead.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

import polars as pl

from oimi import console
from oimi.arg_types import add_world_every_argument
from oimi.batch.app import BatchReport, Interrupted, run_batch
from oimi.batch.executors import default_workers
from oimi.batch.replay import ReplayReport, replay_folder
from oimi.cmd_check import add_outside_paths_argument
from oimi.pipeline.plurals import counted

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
    add_world_every_argument(parser, spec_files=True)
    add_outside_paths_argument(parser)
    parser.add_argument("--replay", type=Path, metavar="DIR", help="redrive every recording in DIR")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    if args.replay is not None:
        return print_replay(replay_folder(args))
    outcome = run_batch(args)
    if isinstance(outcome, Interrupted):
        print(
            f"interrupted after {outcome.finished} of {outcome.total} runs; every finished run"
            f" is kept in {args.out}: run the same command with --resume to finish the batch",
            file=sys.stderr,
        )
        return 130
    return print_report(outcome)


def print_report(report: BatchReport) -> int:
    """The summary, the comparison's groups and the files written; 1 if any run failed."""
    print(report.summary)
    if report.groups is not None:
        groups = report.groups.select(c for c in GROUP_COLUMNS if c in report.groups.columns)
        if "pass rate" in groups.columns:  # a percentage, read as one: 67 %, not 66.667
            rate = pl.col("pass rate").round(0).cast(pl.Int64)
            groups = groups.with_columns(pl.format("{} %", rate).alias("pass rate"))
        with console.table_config(rows=60, width_chars=200):
            print(groups)
    print("results: " + ", ".join(str(p) for p in report.files))
    if report.comparison is not None:
        print(f"comparison: {report.comparison}")
    return 0 if report.ok else 1


def print_replay(report: ReplayReport) -> int:
    """How many recordings replayed identically; each divergence and how to reproduce it."""
    failing = [row for row in report.rows if not row.ok]
    print(
        f"replay: {counted(len(report.rows), 'recording')},"
        f" {len(report.rows) - len(failing)} identical,"
        f" {len(failing)} diverged"
    )
    for row in failing:
        print(f"DIVERGED {row.recording}: {row.detail}")
        print(f"  reproduce: {shlex.join(['oimi', 'replay', str(report.folder / row.recording)])}")
    print(f"results: {report.table}")
    return 1 if failing else 0
