"""`oimi bench --quick` works end to end (a smoke test: it checks the suite, not the machine)."""

from __future__ import annotations

import json
from pathlib import Path

from oimi.cli import main

CASES = {
    "run + MCAP",
    "run + MCAP + Rerun",
    "replay redrive",
    "analyse (load into polars)",
    "compile conditions",
    "evaluate a condition",
    "latency joystick -> command",
    "latency operator stop -> command",
}


def test_the_quick_bench_measures_every_case_and_writes_bench_json(tmp_path: Path, capsys) -> None:
    out = tmp_path / "bench.json"
    assert main(["bench", "--quick", "--repetitions", "1", "--out", str(out)]) == 0
    results = json.loads(out.read_text())
    cases = {c["name"]: c for c in results["cases"]}
    assert set(cases) >= CASES
    for name in CASES - {"latency joystick -> command", "latency operator stop -> command"}:
        assert cases[name]["value"] > 0, name
    assert cases["latency joystick -> command"]["value"] == 0, "an input acts in its own tick"
    assert 0 <= cases["latency operator stop -> command"]["value"] <= 1
    assert "| run + MCAP " in capsys.readouterr().out
