"""Crash safety of `oimi run`: SIGKILL leaves a recoverable prefix named as such
(NAME.partial.mcap), Ctrl-C a finished file under its own name."""

from __future__ import annotations

import io
import itertools
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.exceptions import EndOfFile
from mcap.reader import make_reader
from oimi.pipeline.events import Topic
from oimi.recorder.errors import RecordingError
from oimi.recorder.metadata import StoppedRecord
from oimi.recorder.outputs import partial_path
from oimi.recorder.reader import open_recording
from rerun.chunk import RrdReader

from oimi.cli import main

REPO = Path(__file__).resolve().parents[2]
LONG_SCENARIO = """\
name = "long"
seed = 5
duration_s = 600.0

[robot]
x_m = 3.0
y_m = 2.5

[[humans]]
id = "child"
x_m = 5.0
y_m = 2.6
behaviour = [{ kind = "wander", pause_s = 0.5 }]

[[activities]]
generator = "greeting"
"""
WAIT_LIMIT_S = 60.0


def start_run(tmp_path: Path, *extra: str) -> tuple[subprocess.Popen[bytes], Path]:
    scenario = tmp_path / "long.toml"
    scenario.write_text(LONG_SCENARIO)
    output = tmp_path / "long.mcap"
    process = subprocess.Popen(
        [sys.executable, "-m", "oimi", "run", str(scenario), "-o", str(output), "-q", *extra],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    return process, output


def wait_for_messages(process: subprocess.Popen[bytes], output: Path) -> int:
    """Poll the growing file until at least one chunk of messages is on disk."""
    deadline = time.monotonic() + WAIT_LIMIT_S
    while time.monotonic() < deadline:
        assert process.poll() is None, process.communicate()
        try:
            count = sum(open_recording(output).summary.values())
        except RecordingError:
            count = 0
        if count > 0:
            return count
        time.sleep(0.1)
    process.kill()
    pytest.fail(f"no chunk written within {WAIT_LIMIT_S} s")


class Unseekable(io.BytesIO):
    """A stream read front to back (a pipe): ``make_reader`` then streams the records."""

    def seekable(self) -> bool:
        return False


def mcap_prefix_count(path: Path) -> int:
    """Messages mcap's own ``make_reader`` reads before the end of a truncated file (it
    raises ``EndOfFile`` there, or ``struct.error`` when the kill cut the last write inside a
    record's header: a write of a chunk can be cut short by SIGKILL)."""
    count = 0
    with pytest.raises((EndOfFile, struct.error)):
        for _ in make_reader(Unseekable(path.read_bytes())).iter_messages(log_time_order=False):
            count += 1
    return count


def world_ticks(path: Path) -> list[int]:
    return [m.tick for m in open_recording(path).iter_messages([Topic.WORLD_STATE])]


def assert_every_second_tick(ticks: list[int]) -> None:
    """The world states a recording keeps: from tick 0, every second tick (and those of
    contacts), so no gap is wider than two ticks."""
    assert ticks[0] == 0 and all(0 < b - a <= 2 for a, b in itertools.pairwise(ticks)), ticks


def test_a_killed_run_leaves_a_prefix_that_is_recovered_and_reported(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    process, final = start_run(tmp_path)
    output = partial_path(final)
    assert output.name == "long.partial.mcap"
    try:
        wait_for_messages(process, output)
    finally:
        process.send_signal(signal.SIGKILL)
        process.communicate()
    assert process.returncode == -signal.SIGKILL
    assert not final.exists(), "only the partial file, named as such"

    recording = open_recording(output)
    assert recording.recovery is not None
    assert recording.recovery.messages > 0
    assert "the file ends" in recording.recovery.reason
    assert recording.metadata["scenario"]["name"] == "long"
    ticks = world_ticks(output)
    assert_every_second_tick(ticks)  # a prefix: from tick 0, none missing
    assert all(m.decoded() is not None for m in recording.iter_messages())

    assert mcap_prefix_count(output) == recording.recovery.messages

    assert main(["view", str(output), "--save", str(tmp_path / "killed.rrd")]) == 0
    err = capsys.readouterr().err
    assert f"{output}: damaged at byte {recording.recovery.stopped_at_byte} of " in err
    assert f"recovered: {recording.recovery.messages} messages before it" in err
    assert (tmp_path / "killed.rrd").stat().st_size > 0


def test_ctrl_c_stops_the_run_with_130_and_a_finished_file(tmp_path: Path) -> None:
    rrd = tmp_path / "long.rrd"
    process, output = start_run(tmp_path, "--rrd", str(rrd))
    try:
        wait_for_messages(process, partial_path(output))
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=WAIT_LIMIT_S)
    finally:
        if process.poll() is None:
            process.kill()
            process.communicate()
    assert process.returncode == 130, err
    assert b"interrupted" in err
    assert b"Traceback" not in err
    assert not partial_path(output).exists() and not partial_path(rrd).exists()

    with open(output, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    recording = open_recording(output)
    assert recording.recovery is None
    assert recording.meta.stopped == StoppedRecord(reason="interrupted (Ctrl-C)")
    ticks = world_ticks(output)
    assert len(ticks) > 0
    assert_every_second_tick(ticks)  # and the last, written when the file closed
    assert recording.summary[Topic.WORLD_STATE] == len(ticks)
    assert {r.recording_id for r in RrdReader(rrd).recordings()} == {"long-seed5"}
