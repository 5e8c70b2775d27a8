"""Analyse recorded sessions: activities, goals, rules, commands and safety figures.

One recording: its metric tables. Several (files or folders): one comparison
table, a row per session. ``--out DIR`` also writes the tables (Parquet, CSV),
plots (PNG) and an HTML report.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

from oimi import console
from oimi.analysis.dataset import build_dataset, recordings, safe_name
from oimi.analysis.load import AnalysisWarning, SessionData
from oimi.analysis.metrics import SessionMetrics, Verdicts
from oimi.analysis.report import transposed, write_comparison_report, write_session_report
from oimi.paths import check_output
from oimi.pipeline.errors import LocatedError
from oimi.recorder.metadata import RecordingMetadata
from oimi.recorder.reader import open_recording
from oimi.replay.rebuild import rebuilt_pipeline
from oimi.scenarios.session.expectations import Tracker

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


def run(args: argparse.Namespace) -> int:
    if args.out is not None:
        check_output(args.out, folder=True)
    files = recordings(args.paths)
    single = len(files) == 1
    reports: dict[str, str] = {}

    def on_session(data: SessionData, metrics: SessionMetrics) -> None:
        if single:
            print_session_fields(data.metadata)
            print_session(metrics)
        if args.out is not None:
            folder = args.out if single else args.out / "sessions" / safe_name(data.session_id)
            index = write_session_report(data, metrics, folder)
            reports[data.session_id] = str(index.relative_to(args.out))

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", AnalysisWarning)
        dataset = build_dataset(
            files,
            folder=None if args.out is None or single else args.out,
            on_session=on_session,
            verdicts=recorded_verdicts,
        )
    for warning in caught:
        print(f"warning: {warning.message}", file=sys.stderr)
    if not single:
        with console.table_config():
            print(dataset.comparison.select(COMPARISON_COLUMNS))
        if args.out is not None:
            write_comparison_report(dataset.comparison, args.out, links=reports)
    if args.out is not None:
        print(f"report: {args.out / 'index.html'}")
    return 0


def recorded_verdicts(path: Path) -> Verdicts | None:
    """The expectations of the recording's attached scenario, checked against its messages
    (the verdicts ``oimi run`` printed, which the recording does not hold), streamed;
    None when the recording has no loadable scenario."""
    recording = open_recording(path)
    try:
        with rebuilt_pipeline(recording) as built:
            tracker = Tracker(built.scenario)
    except LocatedError:
        return None
    for message in recording.iter_messages(Tracker.TOPICS):
        tracker.record(message.topic, message.time_ns, message.decoded())
    return [(v.name, v.ok, v.detail) for v in tracker.verdicts()]


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
