"""Each task floor does its run case's work minus the pipeline: the same files, the same world."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

from rerun.chunk import RrdReader

from oimi.bench.runs import run_case, task_floor

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
