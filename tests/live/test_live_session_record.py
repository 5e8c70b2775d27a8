"""A live session recorded as a session: its own id, date and fields, its true length, and
the scenario's scripted expectations reported as not applicable."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from datetime import UTC, datetime
from pathlib import Path

import pytest
from live_helpers import LineClient, served
from oimi.recorder.reader import open_recording
from oimi.replay.expectations import recorded_verdicts
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.session.info import new_session_info

ROOT = Path(__file__).resolve().parents[2]
GREETING = ROOT / "scenarios" / "library" / "greeting.toml"


def oimi(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "oimi", *map(str, args)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.fixture(scope="module")
def live(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """A 1.2 s live session of greeting (a 30 s scenario with expectations), its fields set."""
    path = tmp_path_factory.mktemp("live") / "monday.mcap"
    done = oimi(
        "serve", GREETING, "--no-tcp", "--no-console", "--duration-s", "1.2", "-o", path,
        "--child", "C07", "--therapist", "A. Rossi", "--notes", "first visit; calm",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return path, done.stdout


def test_world_every_sets_the_live_recordings_sampling(tmp_path: Path) -> None:
    path = tmp_path / "every.mcap"
    done = oimi(
        "serve", GREETING, "--no-tcp", "--no-console", "--duration-s", "0.4", "-o", path,
        "--world-every", "1",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    recording = open_recording(path)
    world = [m.tick for m in recording.iter_messages(["/world/state"])]
    assert recording.meta.oimi.world_every == 1 and world == list(range(20))


def test_the_summary_reports_expectations_as_not_applicable(live) -> None:
    _, output = live
    assert "expectations: not applicable to a live session" in output
    assert "FAIL" not in output and "failed" not in output
    assert "child: C07" in output and "therapist: A. Rossi" in output


def test_the_metadata_holds_the_true_length_and_the_session_fields(live) -> None:
    path, _ = live
    recording = open_recording(path)
    session = recording.metadata["session"]
    assert session["ticks"] == "60" and float(session["duration_s"]) == 1.2
    world = [m.tick for m in recording.iter_messages(["/world/state"])]
    assert world[-1] == 59 and len(world) == 31, "every second tick and the last"
    assert (session["child"], session["therapist"]) == ("C07", "A. Rossi")
    assert session["notes"] == "first visit; calm"
    assert datetime.strptime(session["date"], "%Y-%m-%dT%H:%M:%SZ")
    assert "duration_s" not in recording.metadata["scenario"], "the scenario's 30 s is not it"
    rid = recording.metadata["oimi"]["recording_id"]
    assert rid == session["recording_id"] and rid.startswith("greeting-live-")
    assert rid != "greeting-seed1", "not the scripted run's id"


def test_info_and_analyse_show_the_session_fields(live) -> None:
    path, _ = live
    info = json.loads(oimi("info", path, "--json").stdout)
    assert info["live"] is True and info["ticks"] == 60 and info["duration_s"] == 1.2
    assert info["session"]["child"] == "C07" and info["session"]["notes"] == "first visit; calm"
    analysed = oimi("analyse", path)
    assert analysed.returncode == 0, analysed.stderr
    assert "child: C07" in analysed.stdout and "therapist: A. Rossi" in analysed.stdout
    assert recorded_verdicts(path) is None, "the scenario's expectations are not applicable"
    rid = open_recording(path).meta.oimi.recording_id
    assert f"session {rid}\n" in analysed.stdout and "greeting-s1" not in analysed.stdout
    assert re.search(r"\| expectations failed +\| 0 +\|", analysed.stdout), analysed.stdout


def test_the_live_recording_still_redrives_identically(live) -> None:
    path, _ = live
    done = oimi("replay", path)
    assert done.returncode == 0, done.stdout + done.stderr


def test_two_sessions_started_in_the_same_second_get_different_ids() -> None:
    now = datetime(2026, 11, 23, 18, 4, 5, tzinfo=UTC)
    one = new_session_info("room", started=now, suffix="a1b2c3")
    two = new_session_info("room", started=now, suffix="d4e5f6")
    assert one.recording_id == "room-live-20261123T180405Z-a1b2c3"
    assert one.recording_id != two.recording_id and one.date == "2026-11-23T18:04:05Z"


@pytest.mark.parametrize(
    ("field", "value", "why"),
    [("child", "x" * 65, "at most 64"), ("therapist", "A\x1b[2J", "control character")],
)
def test_a_bad_session_field_is_refused(field: str, value: str, why: str) -> None:
    now = datetime(2026, 11, 23, tzinfo=UTC)
    with pytest.raises(ScenarioError, match=why):
        new_session_info("room", started=now, suffix="0", **{field: value})


def test_serve_refuses_a_bad_field_with_exit_2_before_listening(tmp_path: Path) -> None:
    done = oimi("serve", GREETING, "--no-tcp", "--no-console", "--child", "x" * 100,
                "-o", tmp_path / "x.mcap")  # fmt: skip
    assert done.returncode == 2 and "--child" in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "x.mcap").exists()


def test_the_session_request_is_guarded_bounded_and_lands_in_the_end_record(
    tmp_path: Path,
) -> None:
    path = tmp_path / "fields.mcap"
    with served(path, "--token", "s3cret", "--child", "C01", "--no-console") as live:
        assert live.tcp_port is not None
        client = LineClient.connect(live.tcp_port)
        refused = client.call(cmd="session", child="C99")
        assert not refused["ok"] and "unauthorised" in refused["reason"]
        auth = client.send(cmd="auth", token="s3cret")
        client.reply_to(auth)
        hello = client.read()
        assert hello["type"] == "hello"
        assert hello["session"] == {"child": "C01", "therapist": "", "notes": ""}
        too_long = client.call(cmd="session", notes="x" * 2001)
        assert not too_long["ok"] and "length <= 2000" in too_long["reason"]
        control = client.call(cmd="session", therapist="A\x1b[2J")
        assert not control["ok"] and "control character" in control["reason"]
        saved = client.call(cmd="session", therapist="B. Bianchi", notes="two\nlines")
        assert saved["ok"], saved
        fields = {"child": "C01", "therapist": "B. Bianchi", "notes": "two\nlines"}
        assert saved["session"] == fields
        client.close()
        live.stop()
    assert live.returncode == 0, live.errors
    session = open_recording(path).metadata["session"]
    assert (session["child"], session["therapist"], session["notes"]) == (
        "C01",
        "B. Bianchi",
        "two\nlines",
    )
    assert session["ticks"] != "0"
