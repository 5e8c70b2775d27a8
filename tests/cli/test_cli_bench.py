"""`oimi bench --quick` works end to end (a smoke test: it checks the suite, not the machine)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from oimi import accel
from oimi.cli import main

CASES = {
    "run + MCAP",
    "run + MCAP + Rerun",
    "recording per simulated minute",
    "replay redrive",
    "analyse (load into polars)",
    "MCAP writer: foxglove-sdk",
    "compile conditions",
    "evaluate a condition",
    "latency joystick -> command",
    "latency operator stop -> command",
    "cost per person (3 vs 12 people)",
    "memory (2000 vs 1000 ticks)",
    "analyse memory (0.05 h recording)",
}
FLOORS = {
    "run + MCAP": {"floor: its events -> MCAP sink", "floor: its world, no pipeline"},
    "run + MCAP + Rerun": {
        "floor: its events -> MCAP sink",
        "floor: its events -> Rerun sink",
        "floor: its world, no pipeline",
    },
}


def test_the_quick_bench_measures_every_case_and_writes_bench_json(tmp_path: Path, capsys) -> None:
    out = tmp_path / "docs" / "bench.json"
    assert main(["bench", "--quick", "--repetitions", "1", "--out", str(out)]) == 0
    results = json.loads(out.read_text())
    cases = [c for c in results["cases"] if not c["name"].startswith("floor:")]
    assert {c["name"] for c in cases} == CASES
    by_name = {c["name"]: c for c in cases}
    for name, floors in FLOORS.items():
        index = results["cases"].index(by_name[name])
        following = results["cases"][index + 1 : index + 1 + len(floors)]
        assert {c["name"] for c in following} == floors, name
        assert all(c["against"] == name and c["ratio"] > 0 for c in following)
        assert by_name[name]["against"] == "reference loop"
        extra = by_name[name]["extra"]
        assert extra["reference_messages_per_tick"] == 6
        assert extra["floor_wrote_the_runs_messages"] == extra["floor_world_matched_the_runs"] == 1
    run = by_name["run + MCAP"]
    size = by_name["recording per simulated minute"]
    assert size["value"] == run["extra"]["mcap_mb_per_min"] > 0
    assert size["target"] == "<= 0.30, half of format 1's 0.60"
    assert results["headline"]["ratio"] == run["ratio"] == run["value"] / run["against_value"]
    assert by_name["analyse (load into polars)"]["against"].startswith("baseline")
    writer = by_name["MCAP writer: foxglove-sdk"]
    assert writer["against"].startswith("the sink's writer") and writer["ratio"] > 0
    assert writer["extra"]["same_bytes_each_run"] == 1
    assert writer["extra"]["sink_same_bytes_each_run"] == 1
    assert by_name["latency joystick -> command"]["value"] == 0, "an input acts in its own tick"
    assert 0 <= by_name["latency operator stop -> command"]["value"] <= 1
    memory = by_name["memory (2000 vs 1000 ticks)"]["extra"]
    assert memory["short_mb"] > 0 and memory["long_mb"] > 0
    analysis = by_name["analyse memory (0.05 h recording)"]
    assert analysis["against"].startswith("baseline") and analysis["value"] > 0
    assert analysis["extra"]["ticks"] == 0.05 * 3600 * 50  # the recording really is that long
    printed = capsys.readouterr().out
    assert "| run + MCAP " in printed and "| ↳ floor: its world, no pipeline " in printed
    compiled = results["machine"]["compiled_modules"]
    assert f"hot modules compiled: {compiled} of {len(accel.MODULES)}" in printed


@pytest.mark.parametrize("flag", ["--ticks", "--repetitions"])
def test_a_count_below_one_is_refused(flag: str, capsys) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["bench", flag, "0"])
    assert exit_info.value.code == 2
    assert "must be at least 1, got 0" in capsys.readouterr().err
