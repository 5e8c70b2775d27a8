"""The whole suite: every case in order, printed as it goes, written to a results file."""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Final

from oimi import accel
from oimi.bench.measure import Case, in_child
from oimi.bench.pipeline_cases import bench_conditions, bench_latency
from oimi.bench.recordings import bench_analyse, bench_analysis_memory, bench_replay
from oimi.bench.report import format_row, header, write_results
from oimi.bench.runs import bench_crowd, bench_memory, bench_run
from oimi.bench.writers import bench_writers

FULL_TICKS: Final = 180_000
"""One hour at 50 Hz."""
QUICK_TICKS: Final = 1_000
CROWD_TICKS: Final = 30_000
"""Ticks of each run of the cost-per-person case (ten minutes at 50 Hz)."""
ANALYSIS_HOURS: Final = 8.0
"""The recording the analysis-memory case analyses: a working day of sessions."""
QUICK_ANALYSIS_HOURS: Final = 0.05
MEMORY_SHORT_TICKS: Final = 3_000
"""One minute at 50 Hz: the reference of the flat-memory check (``--quick``: its ticks)."""


def run_suite(
    *,
    quick: bool,
    repetitions: int,
    out: Path,
    echo: Callable[[str], None],
    ticks: int | None = None,
) -> list[Case]:
    """Measure every case, print a table row as each finishes, and write ``out``.

    The run cases stretch busy_playroom to ``ticks`` ticks (one hour; ``quick``: 1,000).
    """
    ticks = ticks or (QUICK_TICKS if quick else FULL_TICKS)
    cases: list[Case] = []

    def add(new: list[Case]) -> None:
        for case in new:
            cases.append(case)
            echo(format_row(case))

    compiled = len(accel.ready())
    echo(
        f"hot modules compiled: {compiled} of {len(accel.MODULES)}"
        + (
            ""
            if compiled == len(accel.MODULES)
            else " (make accel compiles them; OIMI_PURE=1: none)"
        )
    )
    echo(header())
    with tempfile.TemporaryDirectory() as folder:
        add(bench_run(ticks, repetitions, folder, rerun=False))
        add(bench_run(ticks, repetitions, folder, rerun=True))
        recording = Path(folder) / "run-mcap.mcap"
        add(bench_replay(recording, repetitions, cases[0].value))
        add(bench_analyse(recording, repetitions))
        add(bench_writers(recording, repetitions))
        add(in_child(bench_conditions, repetitions))  # not after the parent's garbage
        add(bench_latency())
        add([bench_crowd(min(ticks, CROWD_TICKS), repetitions, folder)])
        short_ticks = min(ticks, MEMORY_SHORT_TICKS)
        add([bench_memory(short_ticks, max(ticks, 2 * short_ticks), folder)])
        hours = QUICK_ANALYSIS_HOURS if quick else ANALYSIS_HOURS
        add([bench_analysis_memory(hours, Path(folder))])
    write_results(
        out,
        cases,
        quick=quick,
        ticks=ticks,
        repetitions=repetitions,
        compiled_modules=compiled,
    )
    return cases
