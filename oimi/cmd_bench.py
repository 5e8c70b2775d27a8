"""Run the performance suite: each case against its floor; writes bench.json."""

from __future__ import annotations

import argparse
from pathlib import Path

from oimi.bench import run_suite


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--quick", action="store_true", help="short runs (a smoke test for CI)")
    parser.add_argument("--repetitions", type=int, default=3, help="repetitions per case")
    parser.add_argument("--out", type=Path, default=Path("bench.json"), help="results file")


def run(args: argparse.Namespace) -> int:
    run_suite(quick=args.quick, repetitions=args.repetitions, out=args.out, echo=print)
    print(f"results: {args.out}")
    return 0
