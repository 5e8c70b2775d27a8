"""`oimi batch` compares: 2 scenarios × 2 parameter values × 3 seeds, grouped with
aggregates over the seeds, a plot per metric against the swept parameter, every run below."""

from __future__ import annotations

import re
from pathlib import Path

import polars as pl
from batch_scenarios import write_scenario

from oimi.cli import main

PARAM = "robot.max_speed_mps"


def test_a_sweep_is_compared_by_scenario_and_parameters(tmp_path: Path, capsys) -> None:
    scenarios = [write_scenario(tmp_path, name) for name in ("alpha", "beta")]
    out = tmp_path / "out"
    argv = ["batch", *map(str, scenarios), "--param", f"{PARAM}=0.2", "--param", f"{PARAM}=0.4"]
    assert main([*argv, "--seeds", "3", "--workers", "2", "-q", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert f"| alpha    | {PARAM}=0.2 | 3    |" in printed

    results = pl.read_parquet(out / "results.parquet")
    assert results.height == 12
    assert results["run"][0] == f"alpha-{PARAM}=0.2-s1"

    report = out / "report"
    comparison = pl.read_csv(report / "comparison.csv")
    # one naming scheme: the comparison's run names are the batch's
    assert sorted(comparison["run"]) == sorted(results["run"])
    assert comparison[f"param:{PARAM}"].cast(pl.String).unique().sort().to_list() == ["0.2", "0.4"]
    assert comparison["passed"].all()
    # paths relative to the report, not to where the batch ran
    assert all(p.startswith("../") and not Path(p).is_absolute() for p in comparison["path"])
    assert all((report / p).is_file() for p in comparison["path"])

    groups = pl.read_csv(report / "groups.csv")
    assert groups.select("scenario", f"param:{PARAM}", "runs").rows() == [
        ("alpha", 0.2, 3),
        ("alpha", 0.4, 3),
        ("beta", 0.2, 3),
        ("beta", 0.4, 3),
    ]
    assert (groups["pass rate"] == 100.0).all()
    for metric in ("min_surface_distance_m", "contacts", "max_speed_mps"):
        assert {f"{metric} {a}" for a in ("mean", "spread", "min", "max")} <= set(groups.columns)
    first = groups.row(0, named=True)
    seeds = comparison.filter((pl.col("scenario") == "alpha") & (pl.col(f"param:{PARAM}") == 0.2))[
        "min_surface_distance_m"
    ]
    assert first["min_surface_distance_m mean"] == seeds.mean()
    assert first["min_surface_distance_m min"] == seeds.min()
    # the seeds matter: the wandering child goes elsewhere on each
    assert first["min_surface_distance_m spread"] > 0

    page = (report / "index.html").read_text()
    plots = re.findall(r'alt="([a-z_]+) by param:robot\.max_speed_mps"', page)
    assert {"min_surface_distance_m", "contacts", "max_speed_mps"} <= set(plots)
    assert page.count("<tr>") > 12 + 4  # the groups, then every run
