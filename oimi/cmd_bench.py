"""Run the performance suite: each case beside its reference loop, floor or baseline."""

from __future__ import annotations

import argparse
from pathlib import Path

from oimi.arg_types import positive_int
from oimi.bench.suite import FULL_TICKS, QUICK_TICKS, run_suite


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--quick", action="store_true", help="short runs (a smoke test for CI)")
    parser.add_argument(
        "--repetitions", type=positive_int, default=3, metavar="N", help="repetitions per case"
    )
    parser.add_argument(
        "--ticks",
        type=positive_int,
        metavar="N",
        help=f"ticks per run case (default {FULL_TICKS:,}, one hour; --quick {QUICK_TICKS:,})",
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("bench.json"),
        metavar="FILE",
        help="results file (default bench.json; make bench writes docs/bench.json)",
    )


def run(args: argparse.Namespace) -> int:
    run_suite(
        quick=args.quick,
        repetitions=args.repetitions,
        out=args.out,
        echo=print,
        ticks=args.ticks,
    )
    print(f"results: {args.out}")
    return 0
