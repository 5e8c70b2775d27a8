"""``python -m oimi.accel``: compile the hot modules for this environment's sources."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from oimi.accel import MODULES, accel_dir, build, ready


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m oimi.accel",
        description="Compile oimi's hot modules with Cython (the same results, faster).",
    )
    parser.add_argument("--dir", type=Path, default=None, help="where to keep them")
    parser.add_argument(
        "--optional",
        action="store_true",
        help="without Cython or a C compiler, say so and exit 0 (oimi runs as Python)",
    )
    args = parser.parse_args(argv)
    folder = args.dir or accel_dir()
    try:
        build(folder, say=lambda line: print(f"oimi.accel: {line}", file=sys.stderr))
    except Exception as error:  # a failed build leaves pure Python, and says so
        print(f"oimi.accel: not compiled ({type(error).__name__}: {error})", file=sys.stderr)
        if args.optional:
            print(
                "oimi.accel: oimi runs as pure Python (the same results, slower)", file=sys.stderr
            )
            return 0
        return 1
    compiled = len(ready(folder))
    print(f"oimi.accel: {compiled} of {len(MODULES)} modules compiled in {folder}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
