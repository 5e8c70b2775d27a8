"""Impossible output paths are bad input (exit 2, the path named) for every command, and a
reader that closes the pipe early ends the command quietly."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from oimi.recorder.outputs import OutputError, check_output

from oimi.cli import main

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scenarios" / "library" / "activities" / "test_act.txt"
SCENARIO = ROOT / "scenarios" / "library" / "greeting.toml"


@pytest.fixture
def a_file(tmp_path: Path) -> Path:
    path = tmp_path / "a_file"
    path.write_text("not a folder")
    return path


def test_check_output_accepts_new_files_and_folders_below_existing_ones(tmp_path: Path) -> None:
    assert check_output(tmp_path / "new" / "deeper" / "x.json") == tmp_path / "new/deeper/x.json"
    assert not (tmp_path / "new").exists()  # nothing is made unless asked
    assert check_output(tmp_path / "made", folder=True, create=True).is_dir()
    check_output(tmp_path / "sub" / "x.rrd", create=True)
    assert (tmp_path / "sub").is_dir()


@pytest.mark.parametrize(
    ("relative", "folder", "why"),
    [
        ("a_file/x.json", False, r".*a_file is a file, not a folder"),
        ("a_file/deep/x", True, r".*a_file is a file, not a folder"),
        ("a_file", True, "is a file, not a folder"),
        (".", False, "is a folder, not a file"),
        ("x" * 300 + "/y", False, "cannot write here: File name too long"),
    ],
)
def test_check_output_refuses_impossible_paths_naming_them(
    tmp_path: Path, a_file: Path, relative: str, folder: bool, why: str
) -> None:
    target = tmp_path / relative
    with pytest.raises(OutputError, match=f"^{target}: {why}") as caught:
        check_output(target, folder=folder)
    assert str(caught.value).startswith(f"{target}: ")


def test_a_file_replaced_by_renaming_needs_its_folder_writable_not_itself(tmp_path: Path) -> None:
    if os.geteuid() == 0:
        pytest.skip("root writes anywhere")
    shut = tmp_path / "shut"
    shut.mkdir()
    (shut / "x.mcap").write_bytes(b"")
    shut.chmod(0o555)
    try:
        check_output(shut / "x.mcap")  # written in place: the file itself is writable
        with pytest.raises(OutputError, match=f"cannot write in {shut}: permission denied"):
            check_output(shut / "x.mcap", beside=True)
        with pytest.raises(OutputError, match=f"cannot write in {shut}: permission denied"):
            check_output(shut / "y.mcap")
    finally:
        shut.chmod(0o755)


def test_a_read_only_filesystem_is_refused() -> None:
    if not Path("/proc/sys").is_dir():
        pytest.skip("no /proc")
    with pytest.raises(OutputError, match=r"^/proc/sys/oimi/x\.csv: cannot write in /proc/sys"):
        check_output("/proc/sys/oimi/x.csv")


@pytest.mark.parametrize(
    "command",
    [
        ["compile", str(SCRIPT), "-o", "{bad}/x.json"],
        ["analyse", "{mcap}", "--out", "{bad}/x"],
        ["batch", str(SCENARIO), "--out", "{bad}/x", "-q"],
        ["batch", "--replay", "{folder}", "--out", "{bad}/x", "-q"],
        ["view", "{mcap}", "--save", "{bad}/x.rrd"],
        ["run", str(SCENARIO), "--no-record", "-q", "--junit", "{bad}/x.xml"],
    ],
    ids=["compile", "analyse", "batch", "batch-replay", "view", "run-junit"],
)
def test_every_command_refuses_an_output_under_a_file_with_exit_2(
    tmp_path: Path, a_file: Path, command: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    mcap = tmp_path / "x.mcap"  # never read: the output is checked first
    mcap.write_bytes(b"")
    argv = [word.format(bad=a_file, mcap=mcap, folder=tmp_path) for word in command]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.err.startswith(f"{a_file}/x"), captured.err
    # run's recordings add their own rules (scenarios.session.recording) to the same check
    assert f"{a_file} is a file, not a folder" in captured.err
    assert "Traceback" not in captured.err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a_file", "x.mcap"]


def test_a_closed_pipe_ends_the_command_quietly_with_exit_1() -> None:
    read_end, write_end = os.pipe()
    os.close(read_end)  # the reader of our output is gone before we write
    try:
        process = subprocess.run(
            [sys.executable, "-m", "oimi", "compile", str(SCRIPT)],
            cwd=ROOT,
            stdout=write_end,
            stderr=subprocess.PIPE,
            timeout=60,
        )
    finally:
        os.close(write_end)
    assert process.returncode == 1
    assert process.stderr == b""
