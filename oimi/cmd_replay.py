"""Replay a recording and compare: redrive its pipeline (open loop) or rerun its scenario.

Exit 0 when every message matches (with the count compared per topic), 1 at the
first divergence (topic, tick, field, both values, the messages before it),
2 when the recording cannot be read or rebuilt (another format version, damage).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from replay.compare import format_report
from replay.redrive import redrive
from replay.rerun import rerun

MODES = {"redrive": redrive, "rerun": rerun}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("recording", type=Path, help="session recording (.mcap)")
    parser.add_argument(
        "--mode",
        choices=tuple(MODES),
        default="redrive",
        help="redrive: recorded inputs -> pipeline (default); rerun: the scenario again",
    )


def run(args: argparse.Namespace) -> int:
    comparison = MODES[args.mode](args.recording)
    print(format_report(comparison))
    return 0 if comparison.ok else 1
