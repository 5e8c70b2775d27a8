"""Analyse recorded sessions: activities, goals, rules, commands and safety figures.

One recording: its metric tables. Several (files or folders): one comparison
table, a row per session. ``--out DIR`` also writes the tables (Parquet, CSV),
plots (PNG) and an HTML report.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from oimi import console
from oimi.analysis.analyse import Analysis, analyse
from oimi.analysis.metrics import SessionMetrics
from oimi.analysis.report import transposed
from oimi.recorder.metadata import RecordingMetadata
from oimi.recorder.outputs import check_output
from oimi.replay.expectations import recorded_verdicts

SESSION_TABLES = (
    "expectations",
    "contacts",
    "proximity",
    "safety_interventions",
    "joystick_takeovers",
    "activities",
    "goals",
    "rule_episodes",
    "rules",
    "commands",
    "operator",
    "rejections",
)

COMPARISON_COLUMNS = (
    "run",
    "passed",
    "duration_s",
    "contacts",
    "robot_initiated_contacts",
    "max_closing_speed_mps",
    "min_surface_distance_m",
    "safety_interventions",
    "goals_reached",
    "rule_episodes",
)
"""What the printed comparison shows (the files hold every column)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("paths", nargs="+", type=Path, help="MCAP recordings or folders of them")
    parser.add_argument("--out", type=Path, help="write tables, plots and an HTML report here")
    parser.add_argument(
        "-q", "--quiet", action="store_true", help="no progress (shown for several recordings)"
    )


def run(args: argparse.Namespace) -> int:
    if args.out is not None:
        check_output(args.out, folder=True)
    count = console.Count("analyse", "sessions")
    several = len(args.paths) > 1 or any(path.is_dir() for path in args.paths)
    progress = None if args.quiet or not several else count
    analysis = analyse(args.paths, out=args.out, verdicts=recorded_verdicts, progress=progress)
    if progress is not None:
        count.close()
    print_analysis(analysis)
    if args.out is not None:
        print(f"report: {args.out / 'index.html'}")
    return 1 if analysis.skipped else 0


def print_analysis(analysis: Analysis) -> None:
    """One session's fields and tables, or the comparison; then the warnings (stderr)."""
    if analysis.session is not None:
        metadata, metrics = analysis.session
        print_session_fields(metadata)
        print_session(metrics)
    for warning in analysis.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    for skipped in analysis.skipped:
        print(f"error: left out {skipped}", file=sys.stderr)
    if analysis.session is None:
        with console.table_config():
            print(analysis.comparison.select(COMPARISON_COLUMNS))


def print_session_fields(metadata: RecordingMetadata) -> None:
    """A live session's date, child pseudonym, therapist and notes (from its ``session``
    metadata record); nothing for a scripted run."""
    record = metadata.session
    if record is None:
        return
    print(f"live session on {record.date or '?'}")
    for name in ("child", "therapist", "notes", "duration_s", "ticks"):
        print(f"  {name}: {getattr(record, name) or '-'}")


def print_session(metrics: SessionMetrics) -> None:
    """The session's summary (metric, value) and its non-empty tables."""
    with console.table_config():
        print(f"session {metrics.session_id}")
        print(transposed(metrics.summary))
        for name in SESSION_TABLES:
            frame = metrics[name]
            if frame.height:
                print(f"\n{name}")
                print(frame)
