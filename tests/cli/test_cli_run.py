"""`oimi run` and `oimi demo` through `python -m oimi`: determinism across processes, exit
codes, the failing expectation named, JUnit, located errors."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from pathlib import Path

from cli_process import ROOT, oimi
from oimi.scenarios.session.runner import RunResult, Summary

from oimi.cmd_run import print_result

LIBRARY = ROOT / "scenarios" / "library"


def test_one_scenario_run_twice_in_two_processes_gives_identical_mcap(tmp_path: Path) -> None:
    first, second = tmp_path / "a.mcap", tmp_path / "b.mcap"
    for out in (first, second):
        done = oimi("run", "-q", LIBRARY / "caress_reward.toml", "-o", out)
        assert done.returncode == 0, done.stdout + done.stderr
    assert first.read_bytes() == second.read_bytes()
    assert first.stat().st_size > 10_000


def broken_copy(tmp_path: Path) -> Path:
    """The greeting with one expectation that cannot hold (greeted within 2 s)."""
    text = (LIBRARY / "greeting.toml").read_text()
    text = text.replace("duration_s = 30.0", "duration_s = 4.0")
    text += (
        '\n[[expect]]\nkind = "goal_reached"\nname = "greets at once"\n'
        'goal = "greet_child"\nby_s = 2.0\n'
    )
    path = tmp_path / "greeting_broken.toml"
    path.write_text(text)
    return path


def test_a_broken_expectation_exits_1_and_is_named(tmp_path: Path) -> None:
    junit = tmp_path / "report.xml"
    done = oimi("run", "-q", broken_copy(tmp_path), "--no-record", "--junit", junit)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "FAIL greets at once: reached never" in done.stdout
    assert "PASS the robot finds the child" in done.stdout
    root = ET.parse(junit).getroot()
    failed = [
        case.get("name") for case in root.iter("testcase") if case.find("failure") is not None
    ]
    assert any("greets at once" in (name or "") for name in failed)
    [suite] = root.iter("testsuite")
    assert float(suite.get("time")) > 0, "the run's wall-clock seconds, which a CI shows"
    assert all(case.get("time") for case in suite.iter("testcase"))


def test_a_malformed_scenario_exits_2_with_file_line_col(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "bad"\nduration_s = 10.0\n\n[robot]\nmax_speed_mps = "fast"\n')
    done = oimi("run", "-q", bad, "--no-record")
    assert done.returncode == 2
    assert f"{bad}:5:" in done.stderr
    assert "Traceback" not in done.stderr


def test_demo_writes_mcap_and_rrd_and_says_how_to_open_them(tmp_path: Path) -> None:
    done = oimi("demo", "-q", "--out", tmp_path / "out")
    assert done.returncode == 0, done.stdout + done.stderr
    mcap = tmp_path / "out" / "three_activity_session.mcap"
    rrd = tmp_path / "out" / "three_activity_session.rrd"
    assert mcap.stat().st_size > 0 and rrd.stat().st_size > 0
    assert f"oimi view {rrd}" in done.stdout
    assert "Foxglove" in done.stdout
    assert "0 failed" in done.stdout
    first = mcap.read_bytes()
    again = oimi("demo", "-q", "--out", tmp_path / "out")  # `make demo` twice: replaced on purpose
    assert again.returncode == 0, again.stdout + again.stderr
    assert mcap.read_bytes() == first
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [mcap.name, rrd.name]


def test_demo_rejects_an_unknown_scenario_with_the_choices(tmp_path: Path) -> None:
    done = oimi("demo", "--out", tmp_path, "--scenario", "nope")
    assert done.returncode == 2
    assert "no library scenario 'nope'" in done.stderr and "greeting" in done.stderr


def test_world_every_sets_how_often_the_recording_keeps_the_worlds_state(tmp_path: Path) -> None:
    from oimi.recorder.reader import open_recording

    every = tmp_path / "every.mcap"
    done = oimi("run", "-q", LIBRARY / "greeting.toml", "-o", every, "--world-every", "1")
    assert done.returncode == 0, done.stdout + done.stderr
    recording = open_recording(every)
    ticks = [m.tick for m in recording.iter_messages(["/world/state"])]
    assert ticks == list(range(1500)) and recording.meta.oimi.world_every_n_ticks == "1"
    done = oimi(
        "run", "-q", LIBRARY / "greeting.toml", "-o", tmp_path / "no.mcap", "--world-every", "0"
    )
    assert done.returncode == 2 and "--world-every: must be at least 1, got 0" in done.stderr
    assert not (tmp_path / "no.mcap").exists()


def test_an_output_onto_the_scenario_is_refused_even_with_overwrite(tmp_path: Path) -> None:
    scenario = tmp_path / "caress.toml"
    scenario.write_bytes((LIBRARY / "caress_reward.toml").read_bytes())
    before = scenario.read_bytes()
    done = oimi("run", "-q", scenario, "-o", scenario, "--overwrite")
    assert done.returncode == 2, done.stdout + done.stderr
    assert f"{scenario}: is the input file: refusing to write over it" in done.stderr
    assert scenario.read_bytes() == before


def test_the_summary_says_the_simulated_time_and_the_rules_firing_episodes() -> None:
    done = oimi("run", "-q", LIBRARY / "caress_reward.toml", "--no-record", "--json")
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)["summary"]
    assert (summary["ticks"], summary["duration_s"]) == (1250, 25.0)
    assert summary["rule_episodes"] == {"kick_starter": 1, "touch_reward": 2}
    printed = oimi("run", "-q", LIBRARY / "caress_reward.toml", "--no-record").stdout
    fired = summary["rules_fired"]
    assert (
        f"  rules fired: kick_starter x{fired['kick_starter']} (1 episode),"
        f" touch_reward x{fired['touch_reward']} (2 episodes)\n"
    ) in printed


def test_the_summary_names_an_activity_that_ran_though_the_operator_cleared_it() -> None:
    printed = oimi("run", "-q", LIBRARY / "operator_controls.toml", "--no-record").stdout
    assert "  activity test_dance: completed (no longer selected)\n" in printed
    assert "idle_activity" not in printed


def test_the_summary_says_which_selected_activity_never_started_or_was_interrupted(
    capsys,
) -> None:
    """``oimi run``'s and ``oimi serve``'s summary: the selection alone says
    ``not_yet_completed`` both of an activity never started and of one interrupted."""
    selection = {
        "greeting": "completed",
        "dance": "not_yet_completed",
        "blink": "not_yet_completed",
        "chase": "current",
    }
    ran = {"greeting": "completed", "dance": "interrupted", "ball": "completed"}
    summary = Summary(
        scenario="s", seed=1, ticks=10, duration_s=0.2, activities=selection,
        goals_reached={}, rules_fired={}, min_distance_m={}, max_speed_mps=0.0, contacts=0,
        rejected_inputs=0, ran=ran,
    )  # fmt: skip
    print_result(RunResult(summary=summary, verdicts=()), live=True)
    lines = [line for line in capsys.readouterr().out.splitlines() if "activity " in line]
    assert lines == [
        "  activity greeting: completed",
        "  activity dance: not_yet_completed (started, interrupted)",
        "  activity blink: selected, never started",
        "  activity chase: current, never started",
        "  activity ball: completed (no longer selected)",
    ]


def test_a_run_that_ends_before_an_activity_starts_says_it_never_started() -> None:
    scenario = LIBRARY / "three_activity_session.toml"
    printed = oimi("run", "-q", scenario, "--no-record", "--param", "duration_s=8").stdout
    assert "  activity test_dance: selected, never started\n" in printed


def test_the_summary_counts_rejected_inputs_on_their_own_line_not_with_safety() -> None:
    """A script refused or a rule that raised is no safety figure."""
    printed = oimi("run", "-q", LIBRARY / "blink.toml", "--no-record").stdout
    safety = next(line for line in printed.splitlines() if line.startswith("  safety: "))
    assert "rejected" not in safety
    assert "  rejected inputs: 0\n" in printed
