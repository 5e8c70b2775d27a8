"""`oimi` run as a user runs it: ``python -m oimi`` in its own process, from the repository."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def oimi(*args: str | Path, timeout: float = 120) -> subprocess.CompletedProcess[str]:
    """Run ``oimi ARGS`` to its end: its exit code, stdout and stderr as text."""
    return subprocess.run(
        [sys.executable, "-m", "oimi", *map(str, args)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=timeout,
    )
