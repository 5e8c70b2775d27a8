"""Recordings are never destroyed: `oimi run` and `oimi serve` check every output and bind
their ports before opening a recording, refuse an existing file unless --overwrite, and
say which path is wrong (exit 2, no traceback)."""

from __future__ import annotations

import datetime
import re
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from oimi.recorder.outputs import partial_path
from oimi.scenarios.session.recording import dated_path

from oimi.cli import main

ROOT = Path(__file__).parents[2]
GREETING = ROOT / "scenarios" / "library" / "greeting.toml"
ROOM = ROOT / "tests" / "live" / "live_room.toml"
OLD = b"an earlier session's recording"


@pytest.fixture
def existing(tmp_path: Path) -> Path:
    path = tmp_path / "monday.mcap"
    path.write_bytes(OLD)
    return path


def refused(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    """Run ``oimi ARGV`` in this process; it must exit 2; its stderr."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return err


def test_run_refuses_an_existing_recording_and_replaces_it_only_when_told(
    existing: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    err = refused(capsys, ["run", "-q", str(GREETING), "-o", str(existing)])
    assert f"{existing}: exists: refusing to replace a recording (pass --overwrite" in err
    assert existing.read_bytes() == OLD
    junit = existing.with_suffix(".xml")
    junit.write_text("<old/>")
    other = existing.with_name("other.mcap")
    err = refused(capsys, ["run", "-q", str(GREETING), "-o", str(other), "--junit", str(junit)])
    assert f"{junit}: exists" in err and not other.exists()
    assert junit.read_text() == "<old/>"
    short = ["--param", "duration_s=1.0"]
    assert main(["run", "-q", str(GREETING), "-o", str(existing), "--overwrite", *short]) in (0, 1)
    assert existing.read_bytes().startswith(b"\x89MCAP")
    assert not partial_path(existing).exists()


def test_impossible_outputs_exit_2_with_the_path(
    tmp_path: Path, existing: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    afile = tmp_path / "somefile"
    afile.write_text("not a folder")
    inside = afile / "x.mcap"
    err = refused(capsys, ["run", "-q", str(GREETING), "-o", str(inside)])
    assert f"{inside}: {afile} is a file, not a folder" in err
    # an unwritable --rrd leaves the existing recording as it was, and no partial file
    rrd = afile / "x.rrd"
    argv = ["run", "-q", str(GREETING), "-o", str(existing), "--overwrite", "--rrd", str(rrd)]
    err = refused(capsys, argv)
    assert f"{rrd}: {afile} is a file, not a folder" in err
    assert existing.read_bytes() == OLD
    assert not partial_path(existing).exists()
    err = refused(capsys, ["run", "-q", str(GREETING), "-o", str(tmp_path)])
    assert f"{tmp_path}: is a folder, not a file" in err


def test_serve_with_a_busy_port_or_a_bad_rrd_opens_no_recording(
    tmp_path: Path, existing: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        argv = ["serve", str(ROOM), "-o", str(existing), "--overwrite", "--port", str(port)]
        err = refused(capsys, [*argv, "--http-port", "0"])
    assert f"cannot listen on 127.0.0.1:{port}" in err
    assert existing.read_bytes() == OLD
    assert not partial_path(existing).exists()

    afile = tmp_path / "somefile"
    afile.write_text("")
    argv = ["serve", str(ROOM), "-o", str(existing), "--overwrite", "--rrd", str(afile / "x.rrd")]
    err = refused(capsys, [*argv, "--port", "0", "--http-port", "0"])
    assert f"{afile / 'x.rrd'}: {afile} is a file" in err
    assert existing.read_bytes() == OLD
    assert sorted(p.name for p in tmp_path.iterdir()) == ["monday.mcap", "somefile"]


def test_a_live_session_gets_a_dated_name_of_its_own(tmp_path: Path) -> None:
    done = subprocess.run(
        [
            *(sys.executable, "-m", "oimi", "serve", str(ROOM)),
            *("--port", "0", "--http-port", "0", "--duration-s", "0.2"),
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    names = [p.name for p in (tmp_path / "out").iterdir()]
    assert len(names) == 1
    assert re.fullmatch(r"live_room-\d{4}-\d\d-\d\dT\d\d-\d\d-\d\d\.mcap", names[0]), names
    assert f"recording: out/{names[0]}" in done.stdout


def test_dated_names_never_collide(tmp_path: Path) -> None:
    now = datetime.datetime(2026, 11, 23, 16, 20, 5)
    first = dated_path(tmp_path, "greeting", ".mcap", now=now)
    assert first.name == "greeting-2026-11-23T16-20-05.mcap"
    first.write_bytes(b"")
    second = dated_path(tmp_path, "greeting", ".mcap", now=now)
    assert second.name == "greeting-2026-11-23T16-20-05-2.mcap"
    partial_path(second).write_bytes(b"")  # a session still writing it
    assert dated_path(tmp_path, "greeting", ".mcap", now=now).name.endswith("-3.mcap")
