"""`oimi replay BAG/ --scenario`: the expectations a bag can judge decide the exit code and
``ok`` as in `oimi run`; those about people are not judged (a bag's odometry has no people);
the drive's recording says it came from a bag, so `oimi analyse` judges it alike and
`--mode rerun` refuses it; and `oimi export` to a folder that exists names it once."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytest.importorskip("rosbags", reason="the ros2 extra (rosbags) is not installed")

from oimi.recorder.reader import open_recording
from oimi.replay.expectations import recorded_verdicts

from oimi.cli import main

LIBRARY = Path(__file__).resolve().parents[2] / "scenarios" / "library"
GREETING = LIBRARY / "greeting.toml"


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The greeting (a min_distance expectation on the child) run and exported."""
    folder = tmp_path_factory.mktemp("greeting-bag")
    recording, bag = folder / "session.mcap", folder / "bag"
    assert main(["run", "-q", str(GREETING), "-o", str(recording)]) == 0
    assert main(["export", "--ros2", str(recording), str(bag)]) == 0
    return bag


def replay(bag: Path, scenario: Path, out: Path, capsys: pytest.CaptureFixture[str]):
    """The exit code, what was printed for people, and the JSON summary."""
    code = main(["replay", str(bag), "--scenario", str(scenario), "-o", str(out), "--json"])
    captured = capsys.readouterr()
    return code, captured.err, json.loads(captured.out)


def test_an_expectation_about_people_is_not_judged_from_a_bag(bag, tmp_path, capsys):
    code, printed, summary = replay(bag, GREETING, tmp_path / "again.mcap", capsys)
    assert "FAIL" not in printed and "closest inf" not in printed
    assert "7 passed, 0 failed" in printed
    assert "not judged (the bag has no people): stops about 1 m from the child" in printed
    assert (code, summary["ok"], summary["failed"]) == (0, True, 0)
    names = [v["name"] for v in summary["verdicts"]]
    assert "stops about 1 m from the child" not in names
    assert summary["not_judged"] == [
        {"name": "stops about 1 m from the child", "why": "the bag has no people"}
    ]


def test_a_failed_expectation_on_a_bag_exits_1_and_is_not_ok(bag, tmp_path, capsys):
    text = GREETING.read_text()
    assert "at_most_mps = 0.16" in text
    strict = tmp_path / "greeting_strict.toml"
    strict.write_text(text.replace("at_most_mps = 0.16", "at_most_mps = 0.1"))
    code, printed, summary = replay(bag, strict, tmp_path / "again.mcap", capsys)
    assert "FAIL approaches slowly: max 0.150 m/s" in printed
    assert "6 passed, 1 failed" in printed
    assert (code, summary["ok"], summary["failed"]) == (1, False, 1)


def test_export_to_an_existing_folder_names_it_once(bag, tmp_path, capsys):
    recording = bag.parent / "session.mcap"
    assert main(["export", "--ros2", str(recording), str(bag)]) == 2
    error = capsys.readouterr().err
    assert error.count(str(bag)) == 1, error
    assert "exists already" in error


def test_a_drive_onto_an_existing_recording_is_refused_unless_overwrite(bag, tmp_path, capsys):
    out = tmp_path / "taken.mcap"
    out.write_bytes(b"someone's recording")
    args = ["replay", str(bag), "--scenario", str(GREETING), "-o", str(out)]
    assert main(args) == 2
    assert f"{out}: exists: refusing to replace a recording" in capsys.readouterr().err
    assert out.read_bytes() == b"someone's recording"
    assert main([*args, "--overwrite"]) == 0
    assert out.read_bytes().startswith(b"\x89MCAP")


def test_the_drives_recording_says_so_is_judged_alike_and_not_rerun(bag, tmp_path, capsys):
    out = tmp_path / "again.mcap"
    _, _, summary = replay(bag, GREETING, out, capsys)
    assert open_recording(out).meta.from_bag
    verdicts = recorded_verdicts(out)
    assert verdicts is not None
    assert [(name, ok) for name, ok, _ in verdicts] == [
        (v["name"], v["ok"]) for v in summary["verdicts"]
    ], "oimi analyse judges what the drive judged, nothing about people"
    assert main(["info", str(out)]) == 0
    assert "(driven over a rosbag2)" in capsys.readouterr().out
    assert main(["replay", str(out), "--mode", "rerun"]) == 2
    assert "a recording driven over a rosbag2" in capsys.readouterr().err
    assert main(["replay", str(out)]) == 0, "it redrives"


def test_a_scenario_the_bridge_refuses_is_warned_of_not_refused(bag, tmp_path, capsys):
    """A bag's readings came from a real ring: an ideal one (greeting's) is said, with
    where, and the drive goes on; a scenario with the robot's ring is not."""
    code, printed, summary = replay(bag, GREETING, tmp_path / "again.mcap", capsys)
    assert code == 0
    ideal = [w for w in summary["warnings"] if "is an ideal ring" in w]
    assert len(ideal) == 1 and ideal[0].startswith(f"{GREETING}:")
    assert f"{ideal[0]} (warning)" in printed
    ringed = tmp_path / "greeting_ring.toml"
    text = GREETING.read_text()
    assert "[sensors]" not in text  # the ideal ring by default
    ringed.write_text(f"{text}\n[sensors]\nsonar_beams = 12\n")
    code, printed, summary = replay(bag, ringed, tmp_path / "ringed.mcap", capsys)
    assert not any("ideal ring" in w for w in summary["warnings"])
    assert "ideal ring" not in printed
