"""The scanner trusts no length: each is checked against what is left of the file, the
record or the chunk, and damage is reported at the byte where its record starts; asked
to, it checks that the message indexes list their chunks' messages."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import pytest
import zstandard
from oimi.pipeline.events import Topic
from oimi.recorder.errors import RecordingError
from oimi.recorder.mcap_sink import McapSink
from oimi.recorder.reader import open_recording
from recorder_synthetic import SCENE, session

METADATA = {"oimi": {"recording_id": "scan-test"}}
ATTACHMENTS = [("greeting.toml", b'name = "greeting"\n')]


def records(data: bytes) -> list[tuple[int, int, int]]:
    """(start, opcode, length) of each top-level record."""
    found, at = [], 8
    while at + 9 <= len(data):
        opcode, length = struct.unpack_from("<BQ", data, at)
        found.append((at, opcode, length))
        if opcode == 0x02:
            break
        at += 9 + length
    return found


@pytest.fixture
def whole(tmp_path: Path) -> bytes:
    path = tmp_path / "whole.mcap"
    with McapSink(
        path, metadata=METADATA, attachments=ATTACHMENTS, scene=SCENE, world_every_n_ticks=1
    ) as sink:
        for topic, time_ns, event in session(20):
            sink.record(topic, time_ns, event)
    return path.read_bytes()


def first(data: bytes, opcode: int) -> int:
    return next(start for start, code, _ in records(data) if code == opcode)


def reopen(tmp_path: Path, data: bytes | bytearray):
    path = tmp_path / "damaged.mcap"
    path.write_bytes(bytes(data))
    recording = open_recording(path)
    messages = list(recording.iter_messages())
    return recording, messages


def rewrite_chunk(data: bytearray, chunk: int, records: bytes, *, size: int) -> bytearray:
    """The chunk at ``chunk`` holding ``records`` zstd-compressed, declaring ``size``."""
    (length,) = struct.unpack_from("<Q", data, chunk + 1)
    body = data[chunk + 9 : chunk + 9 + length]
    start, end, _, _, name_length = struct.unpack_from("<QQQII", body)
    compressed = zstandard.ZstdCompressor().compress(records)
    new = (
        struct.pack("<QQQII", start, end, size, zlib.crc32(records), name_length)
        + bytes(body[32 : 32 + name_length])
        + struct.pack("<Q", len(compressed))
        + compressed
    )
    return data[:chunk] + struct.pack("<BQ", 0x06, len(new)) + new + data[chunk + 9 + length :]


@pytest.mark.parametrize("value", [2**63, 2**64 - 1, 2**40])
def test_a_record_length_past_the_end_of_the_file_is_damage_at_that_record(
    whole: bytes, tmp_path: Path, value: int
) -> None:
    data = bytearray(whole)
    chunk = first(data, 0x06)
    data[chunk + 1 : chunk + 9] = struct.pack("<Q", value)
    recording, messages = reopen(tmp_path, data)
    assert messages == []
    assert recording.recovery is not None
    assert recording.recovery.stopped_at_byte == chunk
    assert str(recording.recovery).startswith(
        f"damaged at byte {chunk} of {len(data)} (the file ends inside a chunk record, which"
        f" declares {value} bytes where"
    )


def test_a_chunk_claiming_more_than_its_bytes_can_hold_is_refused_before_decompressing(
    whole: bytes, tmp_path: Path
) -> None:
    data = bytearray(whole)
    chunk = first(data, 0x06)
    data[chunk + 9 + 16 : chunk + 9 + 24] = struct.pack("<Q", 2**50)
    recording, _ = reopen(tmp_path, data)
    assert recording.recovery is not None
    assert "chunk: uncompressed size 1125899906842624 is more than" in recording.recovery.reason


def test_records_overrunning_their_chunk_are_damage(whole: bytes, tmp_path: Path) -> None:
    data = bytearray(whole)
    chunk = first(data, 0x06)
    bad = struct.pack("<BQ", 0x05, 2**62) + b"x" * 30  # a message record "longer" than all
    recording, _ = reopen(tmp_path, rewrite_chunk(data, chunk, bad, size=len(bad)))
    assert recording.recovery is not None
    assert recording.recovery.stopped_at_byte == chunk
    assert "overruns them (30 bytes left)" in recording.recovery.reason


def test_a_size_that_differs_from_the_zstd_frame_is_damage(whole: bytes, tmp_path: Path) -> None:
    data = bytearray(whole)
    chunk = first(data, 0x06)
    records_ = struct.pack("<BQ", 0x07, 4) + b"\0" * 4  # any valid record
    damaged = rewrite_chunk(data, chunk, records_, size=len(records_) + 1)
    recording, _ = reopen(tmp_path, damaged)
    assert recording.recovery is not None
    assert "differs from its zstd frame's 13" in recording.recovery.reason


def test_a_damaged_attachment_is_found_even_with_an_intact_summary(
    whole: bytes, tmp_path: Path
) -> None:
    data = bytearray(whole)
    attachment = first(data, 0x09)
    at = data.index(b'name = "greeting"', attachment)
    data[at] ^= 0x20  # inside the data: only the CRC tells
    recording, _ = reopen(tmp_path, data)
    assert recording.recovery is not None
    assert recording.recovery.stopped_at_byte == attachment
    assert "attachment: attachment 'greeting.toml': CRC mismatch" in recording.recovery.reason


def test_a_string_length_past_its_record_is_damage_not_a_read(whole: bytes, tmp_path: Path) -> None:
    data = bytearray(whole)
    metadata = first(data, 0x0C)
    (length,) = struct.unpack_from("<Q", data, metadata + 1)
    data[metadata + 9 : metadata + 13] = struct.pack("<I", 2**32 - 1)  # the name's length
    data = data[: first(data, 0x0F)]  # no summary: the records are read one by one
    path = tmp_path / "bad.mcap"
    path.write_bytes(bytes(data))
    with pytest.raises(RecordingError) as refused:
        open_recording(path)  # nothing readable: no metadata, no message
    assert str(refused.value) == (
        f"{path}: unreadable MCAP file: damaged at byte {metadata} of {len(data)} (metadata: bad"
        " metadata record: a field of 4294967295 bytes runs past the end of its record"
        f" ({length - 4} bytes left)); recovered: 0 messages before it"
    )


def test_a_changed_summary_is_not_believed_and_is_reported(whole: bytes, tmp_path: Path) -> None:
    data = bytearray(whole)
    statistics = first(data, 0x0B)
    data[statistics + 9 : statistics + 17] = struct.pack("<Q", 10**12)  # the message count
    recording, messages = reopen(tmp_path, data)
    ours = sum(recording.summary[t.value] for t in Topic)  # counted, not the changed count
    assert ours == len(messages) == len(session(20))
    assert recording.recovery is not None
    assert recording.recovery.reason == (
        "summary: CRC mismatch, so its counts and indexes are not used"
    )
    assert recording.recovery.stopped_at_byte == first(data, 0x0F) + 9 + 4  # after data end


def indexed(tmp_path: Path, data: bytes | bytearray) -> tuple[object, int]:
    """The recovery of a full pass that checks the message indexes, and its messages."""
    path = tmp_path / "indexed.mcap"
    path.write_bytes(bytes(data))
    recording = open_recording(path)
    messages = list(recording.iter_messages(check_indexes=True))
    return recording.recovery, len(messages)


def test_a_message_index_that_lists_another_time_is_damage_where_checked(
    whole: bytes, tmp_path: Path
) -> None:
    assert indexed(tmp_path, whole)[0] is None, "a whole file's indexes are right"
    index = first(whole, 0x07)
    data = bytearray(whole)
    data[index + 9 + 2 + 4] ^= 0x01  # the first entry's log time
    recovery, _ = indexed(tmp_path, data)
    assert recovery is not None and recovery.stopped_at_byte == index
    assert "message index: channel" in recovery.reason
    assert "a viewer that seeks would read the wrong messages" in recovery.reason
    recording, messages = reopen(tmp_path, data)
    _, every = reopen(tmp_path, whole)
    assert recording.recovery is None and len(messages) == len(every), "replays read chunks"


def test_a_chunk_whose_messages_no_index_lists_is_damage(whole: bytes, tmp_path: Path) -> None:
    data = bytearray(whole)
    data[first(whole, 0x07)] = 0x7F  # an unknown record instead: skipped, the chunk unlisted
    recovery, _ = indexed(tmp_path, data)
    assert recovery is not None and "that no message index lists" in recovery.reason


def test_info_shows_a_damaged_index(whole: bytes, tmp_path: Path) -> None:
    from oimi.cmd_info import describe

    data = bytearray(whole)
    data[first(whole, 0x07) + 9 + 2 + 4] ^= 0x01
    path = tmp_path / "info.mcap"
    path.write_bytes(bytes(data))
    info = describe(open_recording(path))
    assert not info["complete"] and "message index" in info["recovery"]["reason"]
