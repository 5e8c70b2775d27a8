"""Byte-mutated and truncated recordings through replay (both modes), analysis and view.

A two-second recording of the library's ``greeting`` scenario is damaged the ways a disk
or a careless copy would: cut anywhere, one bit flipped, a length or size field (8 or 4
bytes at a record's start) overwritten with a huge or random value. Every command must end
with exit 0, 1 or 2 and a message naming the file; never a traceback, a hang or a signal.
"""

from __future__ import annotations

import struct
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from oimi.recorder.reader import open_recording
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.recording import recorded
from oimi.scenarios.session.runner import Session

from .fuzzing import assert_clean_outcome, fuzz_settings, run_cli

ROOT = Path(__file__).resolve().parents[2]
LIBRARY_SCENARIO = ROOT / "scenarios" / "library" / "greeting.toml"
HUGE = (2**64 - 1, 2**63, 2**62 + 5, 2**40, 2**32 - 1, 2**31)


@dataclass(frozen=True)
class Sample:
    path: Path
    data: bytes
    records: tuple[int, ...]
    """Where each top-level record starts (its opcode byte)."""


def record_starts(data: bytes) -> tuple[int, ...]:
    starts, at = [], 8
    while at + 9 <= len(data):
        opcode, length = struct.unpack_from("<BQ", data, at)
        starts.append(at)
        if opcode == 0x02:  # footer
            break
        at += 9 + length
    return tuple(starts)


@pytest.fixture(scope="module")
def sample(tmp_path_factory: pytest.TempPathFactory) -> Sample:
    path = tmp_path_factory.mktemp("fuzz_recording") / "greeting.mcap"
    session = Session(load_scenario(LIBRARY_SCENARIO), overrides={"duration_s": "2.0"})
    with recorded(session, mcap=path, rrd=None):
        session.run()
    data = path.read_bytes()
    return Sample(path, data, record_starts(data))


@st.composite
def damage(draw: st.DrawFn, sample: Sample) -> bytes:
    data = bytearray(sample.data)
    kind = draw(st.sampled_from(["cut", "flip", "length", "u32", "metadata"]))
    if kind == "cut":
        return bytes(data[: draw(st.integers(0, len(data) - 1))])
    if kind == "metadata":  # metadata records carry no CRC: a changed byte reads as a value
        start = draw(st.sampled_from([s for s in sample.records if data[s] == 0x0C]))
        (length,) = struct.unpack_from("<Q", data, start + 1)
        at = start + 9 + draw(st.integers(0, length - 1))
        data[at] = draw(st.sampled_from(b"0129.-xe\x00\xff\"'"))
        return bytes(data)
    if kind == "flip":
        at = draw(st.integers(0, len(data) - 1))
        data[at] ^= 1 << draw(st.integers(0, 7))
        return bytes(data)
    # a field near a record's start: its length, a chunk's sizes, a string's length...
    start = draw(st.sampled_from(sample.records))
    at = min(start + draw(st.integers(1, 48)), len(data) - 8)
    if kind == "length":
        value = draw(st.sampled_from(HUGE) | st.integers(0, 2**64 - 1))
        data[at : at + 8] = struct.pack("<Q", value)
    else:
        data[at : at + 4] = struct.pack("<I", draw(st.integers(0, 2**32 - 1)))
    return bytes(data)


COMMANDS = (
    ("replay", "{file}"),
    ("replay", "{file}", "--mode", "rerun"),
    ("analyse", "{file}"),
    ("view", "{file}", "--save", "{out}", "--overwrite"),
)


def check_every_command(path: Path) -> None:
    out = path.with_suffix(".rrd")
    for command in COMMANDS:
        argv = [word.format(file=path, out=out) for word in command]
        code, _, err = run_cli(argv)
        assert_clean_outcome(code, err, located=f"{path}:")
        if code == 0 and command[0] == "replay":
            assert open_recording(path).recovery is None  # a damaged file never replays clean


def test_the_sample_is_clean_for_every_command(sample: Sample) -> None:
    for command in COMMANDS:
        argv = [w.format(file=sample.path, out=sample.path.with_suffix(".rrd")) for w in command]
        code, _, err = run_cli(argv)
        assert code == 0, err


@fuzz_settings(60)
@given(data=st.data())
def test_damaged_recordings_end_with_a_located_exit_for_every_command(
    sample: Sample, data: st.DataObject
) -> None:
    damaged = sample.path.with_name("damaged.mcap")
    damaged.write_bytes(data.draw(damage(sample)))
    check_every_command(damaged)


@pytest.mark.parametrize(
    ("name", "at", "patch"),
    [
        ("record-length", 1, struct.pack("<Q", 2**63)),
        ("chunk-size", None, struct.pack("<Q", 2**63)),
        ("header-length", 1, struct.pack("<Q", 2**40)),
    ],
)
def test_a_changed_length_is_reported_as_damage_at_its_byte(
    sample: Sample, tmp_path: Path, name: str, at: int | None, patch: bytes
) -> None:
    data = bytearray(sample.data)
    chunk = next(s for s in sample.records if data[s] == 0x06)
    start = sample.records[0] if name == "header-length" else chunk
    offset = start + 9 + 16 if at is None else start + at  # a chunk's uncompressed size
    data[offset : offset + 8] = patch
    path = tmp_path / f"{name}.mcap"
    path.write_bytes(bytes(data))
    recording = open_recording(path)  # through its intact summary
    list(recording.iter_messages())
    assert recording.recovery is not None
    assert recording.recovery.stopped_at_byte == start
    for command in ("replay", "analyse"):
        code, _, err = run_cli([command, str(path)])
        assert code == 2
        assert err.startswith(f"{path}: "), err
        assert f"damaged at byte {start} of {len(data)} (" in err


def test_nothing_recoverable_is_refused_by_analyse(sample: Sample, tmp_path: Path) -> None:
    chunk = next(s for s in sample.records if sample.data[s] == 0x06)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(sample.data[: chunk + 20])  # metadata and attachments, no message
    code, _, err = run_cli(["analyse", str(cut)])
    assert code == 2
    assert err.startswith(f"{cut}: nothing recoverable: damaged at byte {chunk} of "), err
    assert "recovered: 0 messages before it" in err


@pytest.mark.parametrize(
    "command",
    [
        ["replay"],
        ["replay", "--mode", "rerun"],
        ["analyse"],
        ["view", "--save", "{out}", "--overwrite"],
    ],
    ids=["redrive", "rerun", "analyse", "view"],
)
def test_as_a_process_a_huge_length_exits_2_without_a_traceback(
    sample: Sample, tmp_path: Path, command: list[str]
) -> None:
    data = bytearray(sample.data)
    chunk = next(s for s in sample.records if data[s] == 0x06)
    data[chunk + 1 : chunk + 9] = struct.pack("<Q", 2**63)
    path = tmp_path / "huge.mcap"
    path.write_bytes(bytes(data))
    argv = [w.format(out=tmp_path / "x.rrd") for w in command]
    process = subprocess.run(
        [sys.executable, "-m", "oimi", argv[0], str(path), *argv[1:]],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    if command[0] == "view":  # the readable prefix is converted, the damage reported
        assert process.returncode == 0, process.stderr
    else:
        assert process.returncode == 2, process.stderr
    assert "Traceback" not in process.stderr
    assert f"{path}: " in process.stderr
    assert f"damaged at byte {chunk} of {len(data)} (the file ends inside a chunk" in (
        process.stderr
    )
