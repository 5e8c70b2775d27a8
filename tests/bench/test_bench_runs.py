"""Each task floor does its run case's work minus the pipeline: the same files, the same world."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

from rerun.chunk import RrdReader

from oimi.bench.report import write_results
from oimi.bench.runs import bench_run, run_case, task_floor

TICKS = 300


def test_the_mcap_floor_writes_the_recorded_runs_file_byte_for_byte(tmp_path: Path) -> None:
    run = run_case(TICKS, str(tmp_path), False)
    floor = task_floor(TICKS, str(tmp_path), False)
    assert (tmp_path / "floor-mcap.mcap").read_bytes() == (tmp_path / "run-mcap.mcap").read_bytes()
    assert floor["messages"] == run["messages"] > TICKS
    assert set(floor["seconds"]) == {"McapSink", "World"}
    assert floor["world_matches"], "the floor's world did not end where the session's did"


def rows(path: Path) -> Counter[str]:
    counts: Counter[str] = Counter()
    for chunk in RrdReader(path).stream().to_chunks():
        counts[chunk.entity_path] += chunk.num_rows
    return counts


def test_the_rerun_floor_logs_what_the_recorded_run_logs(tmp_path: Path) -> None:
    run_case(TICKS, str(tmp_path), True)
    floor = task_floor(TICKS, str(tmp_path), True)
    logged = rows(tmp_path / "run-rerun.rrd")
    assert "/world/robot" in logged and "/rules/chain" in logged
    assert rows(tmp_path / "floor-rerun.rrd") == logged
    mcap = (tmp_path / "run-rerun.mcap").read_bytes()
    assert (tmp_path / "floor-rerun.mcap").read_bytes() == mcap
    assert set(floor["seconds"]) == {"McapSink", "RerunSink", "World"}


def test_the_headline_says_the_spread_of_its_repetitions(tmp_path: Path) -> None:
    """The run's ratio to the reference loop is the medians'; each repetition's own (its run
    over the reference loop run beside it) gives the lowest and the highest, and the
    medians' lies between them with two repetitions (a mediant)."""
    (case, *_) = bench_run(TICKS, 2, str(tmp_path), rerun=False)
    low, high = case.extra["ratio_lowest"], case.extra["ratio_highest"]
    assert 0 < low <= case.ratio <= high  # type: ignore[operator]
    write_results(
        tmp_path / "bench.json",
        [case],
        quick=True,
        ticks=TICKS,
        repetitions=2,
        compiled_modules=0,
    )
    headline = json.loads((tmp_path / "bench.json").read_text())["headline"]
    assert (headline["ratio_lowest"], headline["ratio_highest"]) == (low, high)
