"""`oimi batch` end to end: process pool and Ray agree, failures are named, resume skips."""

from __future__ import annotations

import os
import shlex
import sys
from pathlib import Path
from xml.etree import ElementTree

import polars as pl
import pytest
from batch_scenarios import write_scenario
from oimi.recorder.reader import open_recording
from polars.testing import assert_frame_equal

from oimi.batch.app import BatchReport
from oimi.cli import main
from oimi.cmd_batch import print_report


def batch(tmp_path: Path, out: str, *extra: str) -> list[str]:
    scenarios = [write_scenario(tmp_path, name) for name in ("alpha", "beta")]
    return ["batch", *map(str, scenarios), "--seeds", "3", "--out", str(tmp_path / out), *extra]


def ray_or_skip() -> None:
    try:
        import ray  # noqa: F401
    except ImportError:
        if os.environ.get("OIMI_REQUIRE_RAY") == "1":
            raise
        pytest.skip("ray is not installed (pip install 'oimi[ray]'); OIMI_REQUIRE_RAY=1 fails")


def test_pool_and_local_ray_give_identical_tables_and_recordings(tmp_path: Path, capsys) -> None:
    ray_or_skip()
    assert main(batch(tmp_path, "pool", "--workers", "2", "-q")) == 0
    assert main(batch(tmp_path, "ray", "--ray", "--workers", "2", "-q")) == 0
    import ray

    assert not ray.is_initialized()
    pool = pl.read_parquet(tmp_path / "pool" / "results.parquet")
    assert_frame_equal(pool, pl.read_parquet(tmp_path / "ray" / "results.parquet"))
    assert (tmp_path / "pool" / "results.csv").read_bytes() == (
        tmp_path / "ray" / "results.csv"
    ).read_bytes()
    assert pool["run"].to_list() == [f"{s}-s{n}" for s in ("alpha", "beta") for n in (1, 2, 3)]
    assert pool["ok"].all()
    assert pool.columns[:4] == ["run", "scenario", "file", "seed"]
    assert {"expect:speed <= 0.5 m/s", "min_surface_distance_m:child", "max_speed_mps"} <= set(
        pool.columns
    )
    # the seed matters (the child wanders), and each recording is the same on both executors
    assert pool.filter(pl.col("scenario") == "alpha")["min_surface_distance_m"].n_unique() > 1
    for name in pool["recording"]:
        assert (tmp_path / "pool" / name).read_bytes() == (tmp_path / "ray" / name).read_bytes()
    assert "batch: 6 runs, 6 passed, 0 failed" in capsys.readouterr().out


def test_a_failing_expectation_exits_1_and_names_the_run_and_its_reproduction(
    tmp_path: Path, capsys
) -> None:
    good = write_scenario(tmp_path, "good")
    bad = write_scenario(tmp_path, "bad", at_least_m=9.0)
    out = tmp_path / "out"
    argv = ["batch", str(good), str(bad), "--param", "robot.max_speed_mps=0.4", "--out", str(out)]
    assert main([*argv, "-q"]) == 1
    text = capsys.readouterr().out
    assert "batch: 2 runs, 1 passed, 1 failed" in text
    assert "FAIL bad-robot.max_speed_mps=0.4-s1" in text
    assert "distance to child >= 9.0 m: closest" in text
    command = next(line for line in text.splitlines() if "reproduce:" in line)
    words = shlex.split(command.split("reproduce:", 1)[1])
    assert words[:2] == ["oimi", "run"] and "--param" in words
    assert (out / "summary.txt").read_text().startswith("batch: 2 runs, 1 passed, 1 failed")
    suites = ElementTree.parse(out / "junit.xml").getroot()
    failures = [
        case.get("classname")
        for case in suites.iter("testcase")
        if case.find("failure") is not None
    ]
    assert failures == ["bad-robot.max_speed_mps=0.4-s1"]
    # the command reproduces the run exactly: same verdict, byte-identical recording
    again = tmp_path / "again.mcap"
    words[words.index("-o") + 1] = str(again)
    assert main([*words[1:], "-q"]) == 1
    batch_recording = out / "bad-robot.max_speed_mps=0.4-s1.mcap"
    assert again.read_bytes() == batch_recording.read_bytes()
    recording = open_recording(batch_recording)
    assert recording.metadata["variation"] == {"robot.max_speed_mps": "0.4"}
    assert recording.metadata["scenario"]["seed"] == "1"


def test_the_reproduce_command_runs_as_printed_with_the_batchs_extension_and_sampling(
    tmp_path: Path, capsys
) -> None:
    scenario = write_scenario(tmp_path, "popping", at_least_m=9.0)
    scenario.write_text(scenario.read_text().replace('"greeting"', '"bubbles"'))  # the extension's
    bubbles = Path(__file__).resolve().parents[2] / "examples" / "bubbles" / "bubbles"
    out = tmp_path / "out"
    argv = ["batch", str(scenario), "--extension", str(bubbles), "--world-every", "1"]
    assert main([*argv, "--out", str(out), "-q"]) == 1
    command = next(line for line in capsys.readouterr().out.splitlines() if "reproduce:" in line)
    words = shlex.split(command.split("reproduce:", 1)[1])
    [failure] = ElementTree.parse(out / "junit.xml").getroot().iter("failure")
    assert failure.text.endswith(f"\nreproduce:{command.split('reproduce:', 1)[1]}")  # for a CI
    for _ in range(2):  # as printed, twice: it never needs the batch's recording moved away
        assert main([*words[1:], "-q"]) == 1, capsys.readouterr()
    again = out / "reproduced" / "popping-s1.mcap"
    assert again.read_bytes() == (out / "popping-s1.mcap").read_bytes()


def test_the_printed_pass_rate_reads_as_a_percentage(capsys) -> None:
    """It printed '100.000' and '66.667', three decimals of a share of a few seeds."""
    groups = pl.DataFrame(
        {"scenario": ["a", "b"], "params": ["", ""], "runs": [3, 3], "pass rate": [100.0, 200 / 3]}
    )
    report = BatchReport(rows=[], summary="batch: 6 runs", files=[], groups=groups, comparison=None)
    assert print_report(report) == 0
    rows = [
        line.split("|")
        for line in capsys.readouterr().out.splitlines()
        if "| a " in line or "| b " in line
    ]
    assert [row[4].strip() for row in rows] == ["100 %", "67 %"]


def test_a_resumed_batch_skips_finished_runs(tmp_path: Path, capsys) -> None:
    argv = batch(tmp_path, "out", "--workers", "2", "-q")
    out = tmp_path / "out"
    assert main(argv) == 0
    first = pl.read_csv(out / "results.csv")
    assert all(float(suite.get("time")) > 0 for suite in junit_suites(out)), "CI durations"
    lost = out / "beta-s2.mcap"
    lost.unlink()  # as if the batch was interrupted before this run finished
    stamps = {p.name: p.stat().st_mtime_ns for p in out.glob("*.mcap")}
    capsys.readouterr()
    assert main([*argv, "--resume"]) == 0
    assert "resuming: 5 of 6 runs already finished" in capsys.readouterr().err
    assert lost.is_file()
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.mcap") if p != lost} == stamps
    assert_frame_equal(pl.read_csv(out / "results.csv"), first)
    # only the run of this batch has a wall-clock time (the results table has none)
    timed = [suite.get("name") for suite in junit_suites(out) if suite.get("time")]
    assert timed == ["beta-s2"]


def junit_suites(out: Path) -> list[ElementTree.Element]:
    return list(ElementTree.parse(out / "junit.xml").getroot().iter("testsuite"))


def test_a_finished_run_of_other_inputs_is_not_taken_for_this_one(tmp_path: Path) -> None:
    from oimi.batch.spec import expand
    from oimi.batch.tasks import finished_row, run_task

    path = write_scenario(tmp_path, "alpha")
    task = expand([path], params={}, seeds=1, seed_range=None, out_dir=tmp_path)[0]
    row = run_task(task)
    assert row.ok and finished_row(task) == row
    other_folder = type(task)(
        name=task.name, scenario=task.scenario, seed=task.seed, out_dir=str(tmp_path / "x")
    )
    assert finished_row(other_folder) is None
    task.mcap.unlink()
    assert finished_row(task) is None


def test_a_run_replaces_its_unfinished_recording_and_leaves_only_its_two_files(
    tmp_path: Path,
) -> None:
    from oimi.batch.spec import expand
    from oimi.batch.tasks import run_task

    path = write_scenario(tmp_path, "alpha")
    out = tmp_path / "out"
    out.mkdir()
    task = expand([path], params={}, seeds=1, seed_range=None, out_dir=out)[0]
    task.mcap.write_bytes(b"a lost worker's recording, without its row")
    assert run_task(task).ok
    assert sorted(p.name for p in out.iterdir()) == ["alpha-s1.mcap", "alpha-s1.result.json"]
    assert open_recording(task.mcap).meta.oimi.world_every == task.world_every_n_ticks


def test_world_every_sets_each_runs_sampling_and_a_resume_with_another_runs_again(
    tmp_path: Path, capsys
) -> None:
    """``--world-every 1`` keeps every tick's world state (the default every second tick);
    a resume asking for another sampling does not take the runs recorded with the first."""
    out = tmp_path / "out"
    argv = ["batch", str(write_scenario(tmp_path, "alpha")), "--out", str(out), "-q"]
    assert main([*argv, "--world-every", "1"]) == 0
    recording = open_recording(out / "alpha-s1.mcap")
    ticks = [m.tick for m in recording.iter_messages(["/world/state"])]
    assert recording.meta.oimi.world_every == 1 and ticks == list(range(len(ticks)))
    capsys.readouterr()
    assert main([*argv, "--resume"]) == 0
    assert "resuming" not in capsys.readouterr().err
    ticks = [m.tick for m in open_recording(out / "alpha-s1.mcap").iter_messages(["/world/state"])]
    assert ticks[:3] == [0, 2, 4]
    with pytest.raises(SystemExit) as exit_info:
        main([*argv, "--world-every", "0"])
    assert exit_info.value.code == 2
    assert "--world-every: must be at least 1" in capsys.readouterr().err


def test_a_bad_param_is_bad_input_before_any_run(tmp_path: Path, capsys) -> None:
    argv = batch(tmp_path, "out", "--param", "robot.max_speed=0.3")
    assert main(argv) == 2
    assert "override 'robot.max_speed': no field 'max_speed'" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_a_param_that_shortens_the_sonar_ring_is_warned_of_once(tmp_path: Path, capsys) -> None:
    argv = batch(tmp_path, "out", "--param", "sensors.sonar_range_m=0.5", "--seeds", "1", "-q")
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert err.count("<overrides>: sensors.sonar_range_m (m): the sonar ring reaches 0.5 m") == 1
    assert err.count("(warning)") == 1, "once, not for each scenario or run"


def test_ray_missing_says_how_to_install_it(tmp_path: Path, capsys, monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)
    assert main(batch(tmp_path, "out", "--ray")) == 2
    assert "pip install 'oimi[ray]'" in capsys.readouterr().err


def test_oimi_run_records_its_param_overrides(tmp_path: Path, capsys) -> None:
    path = write_scenario(tmp_path, "alpha")
    output = tmp_path / "run.mcap"
    argv = ["run", str(path), "-o", str(output), "-q", "--param", "robot.max_speed_mps=0.2"]
    assert main(argv) == 0
    recording = open_recording(output)
    assert recording.metadata["variation"] == {"robot.max_speed_mps": "0.2"}
    assert '"max_speed_mps":0.2' in recording.metadata["configuration"]["robot"]
    assert main([*argv, "--param", "robot.max_speed_mps=0.1"]) == 2
    assert "given twice" in capsys.readouterr().err


def test_batch_replay_redrives_every_recording_of_a_folder(tmp_path: Path, capsys) -> None:
    path = write_scenario(tmp_path, "alpha")
    out = tmp_path / "out"
    # a speed limit the greeting hits: the redrive must apply the recorded override to match
    argv = ["batch", str(path), "--param", "robot.max_speed_mps=0.05", "--seeds", "2"]
    assert main([*argv, "--out", str(out), "-q"]) == 0
    assert main(["batch", "--replay", str(out), "--out", str(tmp_path / "check"), "-q"]) == 0
    assert "replay: 2 recordings, 2 identical, 0 diverged" in capsys.readouterr().out
    table = pl.read_csv(tmp_path / "check" / "replay.csv")
    assert table["ok"].to_list() == [True, True]
    (out / "broken.mcap").write_bytes(b"not a recording")
    assert main(["batch", "--replay", str(out), "--out", str(tmp_path / "check"), "-q"]) == 1
    text = capsys.readouterr().out
    assert "replay: 3 recordings, 2 identical, 1 diverged" in text
    assert "DIVERGED broken.mcap:" in text
    assert "reproduce: oimi replay " in text
