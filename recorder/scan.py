"""A fast, streaming pass over an MCAP file's records, for the reader, replay and analysis.

mcap's own stream reader builds an object per record and trusts every length in
the file; this scanner walks the records itself: each record's length is checked
against what is left of the file, each field's length against what is left of
its record, each chunk's sizes against the chunk (its uncompressed size against
what its compressed bytes can hold), before anything is read or allocated. Chunks
are decompressed once (CRC checked) and their message records sliced out. The
scan stops quietly at the first damage and says where and why
(:class:`RecoveryReport`), so a truncated or damaged recording is read up to its
last complete record.
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Iterator
from typing import IO, Final, NamedTuple

import msgspec
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.records import Attachment, Channel, Metadata

MAGIC: Final = b"\x89MCAP0\r\n"
_FOOTER: Final = 0x02
_CHANNEL: Final = 0x04
_MESSAGE: Final = 0x05
_CHUNK: Final = 0x06
_MESSAGE_INDEX: Final = 0x07
_ATTACHMENT: Final = 0x09
_METADATA: Final = 0x0C
_DATA_END: Final = 0x0F
_RECORD_HEADER: Final = struct.Struct("<BQ")
_U64: Final = struct.Struct("<Q")
_INDEX_HEADER: Final = struct.Struct("<HI")
"""Message index: channel id, byte length of its (log time, offset) entries."""
_INDEX_ENTRY: Final = struct.Struct("<QQ")
_CHUNK_HEADER: Final = struct.Struct("<QQQII")
"""Chunk: start and end time, uncompressed size and CRC, compression name length."""
_MESSAGE_HEADER: Final = struct.Struct("<HIQQ")
"""Message: channel id, sequence, log time, publish time."""
_ZSTD_BLOCK: Final = 128 * 1024
_ZSTD_BLOCK_MIN: Final = 4
"""A zstd block yields at most 128 KiB and takes at least 4 bytes (an RLE block), so
a chunk's compressed bytes bound its uncompressed size."""


class Damage(Exception):
    """What is wrong with the record that starts at byte ``at`` of the file."""

    def __init__(self, at: int, what: str) -> None:
        super().__init__(what)
        self.at = at
        self.what = what


class RecoveryReport(msgspec.Struct, frozen=True, kw_only=True):
    """How much of a damaged recording could be read, and why reading stopped."""

    messages: int
    """Messages read (all channels) before the damage."""
    stopped_at_byte: int
    """Where the damaged record starts (the end of the last complete one)."""
    file_size: int
    reason: str

    def __str__(self) -> str:
        return (
            f"damaged at byte {self.stopped_at_byte} of {self.file_size} ({self.reason});"
            f" recovered: {self.messages} messages before it"
        )


class Scanned(NamedTuple):
    """One message of a wanted topic: where it was logged and its payload bytes."""

    topic: str
    sequence: int
    log_time_ns: int
    data: bytes


class _Body:
    """A record's bytes as a stream for mcap's record parsers: a field longer than
    what is left of the record is damage, never a large read."""

    def __init__(self, data: bytes | memoryview) -> None:
        self.data = data
        self.at = 0

    def read(self, size: int) -> bytes:
        if not 0 <= size <= len(self.data) - self.at:
            raise EOFError(
                f"a field of {size} bytes runs past the end of its record"
                f" ({len(self.data) - self.at} bytes left)"
            )
        start = self.at
        self.at += size
        return bytes(self.data[start : self.at])


def _parse(kind: type, body: bytes | memoryview):
    try:
        return kind.read(ReadDataStream(_Body(body)))  # type: ignore[attr-defined]
    except (EOFError, ValueError, struct.error) as error:
        raise ValueError(f"bad {kind.__name__.lower()} record: {error}") from None


def attachment(body: bytes) -> Attachment:
    """An attachment record's body, its lengths and CRC checked (ValueError if damaged)."""
    record = _parse(Attachment, body)
    (crc,) = struct.unpack_from("<I", body, len(body) - 4)  # of the record before it
    if crc and zlib.crc32(memoryview(body)[:-4]) != crc:
        raise ValueError(f"attachment {record.name!r}: CRC mismatch")
    return record


class ChunkScan:
    """Streams the messages of the ``wanted`` topics in file order.

    After iteration, :meth:`report` is None for a complete file, else says where
    the damage is and how much was read; ``good_byte`` is where the last complete
    record ended and ``count`` the messages (of every topic) read before it.
    With ``keep_records`` (opening a file without a usable summary) the
    metadata, attachments and message counts per topic are kept too
    (``metadata``, ``attachments``, ``counts``) and the summary section is walked
    up to the footer (a cut summary is damage); without, the scan ends with the
    data section. With ``check_indexes`` each chunk's message index records must list
    exactly its messages (log time and place, per channel): a viewer that seeks, as
    Foxglove does, reads through them, and no CRC covers them.
    """

    def __init__(
        self,
        stream: IO[bytes],
        wanted: frozenset[str],
        *,
        keep_records: bool = False,
        check_indexes: bool = False,
    ) -> None:
        self.stream = stream
        self.wanted = wanted
        self.keep_records = keep_records
        self._unindexed: dict[int, list[tuple[int, int]]] | None = {} if check_indexes else None
        """Per channel, the (log time, offset) of the last chunk's messages no index has
        listed yet (None: indexes not checked)."""
        self.size = os.fstat(stream.fileno()).st_size
        self.channels: dict[int, str] = {}
        """Channel id -> topic, every channel seen."""
        self.counts: dict[str, int] = {}
        self.metadata: dict[str, dict[str, str]] = {}
        self.attachments: dict[str, bytes] = {}
        self.damage: Damage | None = None
        self.count = 0
        self.good_byte = 0
        self._zstd = zstandard.ZstdDecompressor()

    @property
    def error(self) -> Damage | None:
        return self.damage

    def report(self) -> RecoveryReport | None:
        """The recovery report of a damaged file (None when the scan found no damage)."""
        if self.damage is None:
            return None
        return RecoveryReport(
            messages=self.count,
            stopped_at_byte=self.damage.at,
            file_size=self.size,
            reason=self.damage.what,
        )

    def messages(self) -> Iterator[Scanned]:
        """The wanted messages; raises ValueError when the file is not MCAP at all."""
        read = self.stream.read
        if read(len(MAGIC)) != MAGIC:
            raise ValueError("not an MCAP file (bad magic bytes)")
        self.good_byte = at = len(MAGIC)
        try:
            while True:
                head = read(_RECORD_HEADER.size)
                if not head:
                    raise Damage(
                        at,
                        "the file ends without its summary and footer (the writer did not finish)",
                    )
                if len(head) < _RECORD_HEADER.size:
                    raise Damage(at, "the file ends inside a record header")
                opcode, length = _RECORD_HEADER.unpack(head)
                if opcode == _FOOTER or (opcode == _DATA_END and not self.keep_records):
                    if self._unindexed:  # the last chunk's indexes fell short
                        try:
                            self._all_indexed()
                        except ValueError as error:
                            raise Damage(at, f"message index: {error}") from None
                    return
                left = self.size - at - _RECORD_HEADER.size
                if length > left:
                    raise Damage(
                        at,
                        f"the file ends inside a {_NAMES.get(opcode, 'record')} record, which"
                        f" declares {length} bytes where {left} are left: truncated, or a"
                        " damaged length",
                    )
                body = read(length)
                if len(body) != length:
                    raise Damage(at, "the file ends inside a record (it shrank while read)")
                try:
                    found = self._record(opcode, body)
                except (ValueError, struct.error, zstandard.ZstdError) as error:
                    raise Damage(at, f"{_NAMES.get(opcode, 'record')}: {error}") from None
                if found:
                    yield from found
                at += _RECORD_HEADER.size + length
                self.good_byte = at
        except Damage as damage:
            self.damage = damage

    def _record(self, opcode: int, body: bytes) -> list[Scanned]:
        if self._unindexed is not None:
            if opcode == _MESSAGE_INDEX:
                self._check_index(body)
                return []
            self._all_indexed()
        if opcode == _CHUNK:
            return self._chunk(body)
        if opcode == _CHANNEL:
            self._channel(body)
        elif opcode == _MESSAGE:
            found: list[Scanned] = []
            self._message(body, 0, len(body), found)
            self.count += 1
            return found
        elif self.keep_records and opcode == _METADATA:
            record = _parse(Metadata, body)
            self.metadata[record.name] = dict(record.metadata)
        elif self.keep_records and opcode == _ATTACHMENT:
            record = attachment(body)
            self.attachments[record.name] = record.data
        return []

    def _check_index(self, body: bytes) -> None:
        """A message index record must list the last chunk's messages on its channel."""
        if len(body) < _INDEX_HEADER.size:
            raise ValueError(f"{len(body)} bytes are too few for its header")
        channel, length = _INDEX_HEADER.unpack_from(body)
        if length != len(body) - _INDEX_HEADER.size or length % _INDEX_ENTRY.size:
            raise ValueError(f"channel {channel}: entries of {length} bytes do not fit the record")
        listed = sorted(_INDEX_ENTRY.iter_unpack(memoryview(body)[_INDEX_HEADER.size :]))
        assert self._unindexed is not None
        held = sorted(self._unindexed.pop(channel, []))
        if listed == held:
            return
        topic = f"channel {channel} ({self.channels.get(channel, 'undeclared')})"
        if len(listed) != len(held):
            wrong = f"lists {len(listed)} messages where its chunk has {len(held)}"
        else:
            (time, place), (real_time, real_place) = next(
                pair for pair in zip(listed, held, strict=True) if pair[0] != pair[1]
            )
            wrong = (
                f"lists a message at log time {time}, byte {place} of its chunk, where the"
                f" chunk has one at {real_time}, byte {real_place}"
            )
        raise ValueError(f"{topic} {wrong}: a viewer that seeks would read the wrong messages")

    def _all_indexed(self) -> None:
        """Past the last chunk's indexes, every message of it must have been listed."""
        assert self._unindexed is not None
        if self._unindexed:
            channel = min(self._unindexed)
            raise ValueError(
                f"the chunk before has messages on channel {channel}"
                f" ({self.channels.get(channel, 'undeclared')}) that no message index lists"
            )

    def _channel(self, body: bytes | memoryview) -> None:
        record = _parse(Channel, body)
        self.channels[record.id] = record.topic
        self.counts.setdefault(record.topic, 0)

    def _message(self, data: bytes, start: int, end: int, found: list[Scanned]) -> None:
        """The message record ``data[start:end]``: its payload kept when its topic is wanted."""
        if end - start < _MESSAGE_HEADER.size:
            raise ValueError(f"a message record of {end - start} bytes is shorter than its header")
        channel, sequence, log_time, _ = _MESSAGE_HEADER.unpack_from(data, start)
        topic = self.channels.get(channel)
        if topic is None:
            raise ValueError(f"a message on channel {channel}, which no channel record declares")
        if self.keep_records:
            self.counts[topic] += 1
        if topic in self.wanted:
            payload = data[start + _MESSAGE_HEADER.size : end]
            found.append(Scanned(topic, sequence, log_time, payload))

    def _chunk(self, body: bytes) -> list[Scanned]:
        if len(body) < _CHUNK_HEADER.size + _U64.size:
            raise ValueError(f"{len(body)} bytes are too few for a chunk's header")
        _, _, size, crc, name_length = _CHUNK_HEADER.unpack_from(body)
        at = _CHUNK_HEADER.size
        if name_length > len(body) - at - _U64.size:
            raise ValueError(f"compression name of {name_length} bytes overruns the chunk")
        compression = body[at : at + name_length].decode()
        at += name_length
        (records_length,) = _U64.unpack_from(body, at)
        at += _U64.size
        if records_length != len(body) - at:
            raise ValueError(
                f"records length {records_length} does not match the {len(body) - at} bytes"
                " left in the chunk"
            )
        data = self._decompress(body[at:], compression, size, crc)
        header, end, message = _RECORD_HEADER, len(data), self._message
        found: list[Scanned] = []
        offset, count = 0, 0
        counts = dict(self.counts)
        index = self._unindexed
        try:
            while offset < end:
                if end - offset < header.size:
                    raise ValueError(f"a record header at byte {offset} overruns the records")
                opcode, length = header.unpack_from(data, offset)
                start = offset + header.size
                if length > end - start:
                    raise ValueError(
                        f"a record of {length} bytes at byte {offset} of the records overruns"
                        f" them ({end - start} bytes left)"
                    )
                at, offset = offset, start + length
                if opcode == _MESSAGE:
                    count += 1
                    message(data, start, offset, found)
                    if index is not None:
                        _index_message(index, data, start, at)
                elif opcode == _CHANNEL:
                    self._channel(data[start:offset])
        except ValueError:
            self.counts = counts  # a chunk counts whole or not at all
            raise
        self.count += count
        return found

    def _decompress(self, data: bytes, compression: str, size: int, crc: int) -> bytes:
        if compression == "zstd":
            most = (len(data) // _ZSTD_BLOCK_MIN + 1) * _ZSTD_BLOCK
            if size > most:
                raise ValueError(
                    f"uncompressed size {size} is more than {len(data)} compressed bytes can"
                    f" hold, at most {most}"
                )
            declared = zstandard.frame_content_size(data)
            if declared >= 0 and declared != size:
                raise ValueError(
                    f"uncompressed size {size} differs from its zstd frame's {declared}"
                )
            data = self._zstd.decompress(data, max_output_size=size)
        elif compression != "":
            raise ValueError(f"unsupported chunk compression {compression!r}")
        if len(data) != size:
            raise ValueError(f"uncompressed size {size}, but the records take {len(data)} bytes")
        if crc and zlib.crc32(data) != crc:
            raise ValueError("CRC mismatch")
        return data


def _index_message(
    index: dict[int, list[tuple[int, int]]], data: bytes, start: int, at: int
) -> None:
    """Note the message whose record starts at ``at`` (its body, read already, at
    ``start``) for the chunk's index check."""
    channel, _, log_time, _ = _MESSAGE_HEADER.unpack_from(data, start)
    index.setdefault(channel, []).append((log_time, at))


_NAMES: Final = {
    0x01: "header",
    0x03: "schema",
    _CHANNEL: "channel",
    _MESSAGE: "message",
    _CHUNK: "chunk",
    _ATTACHMENT: "attachment",
    _METADATA: "metadata",
    _MESSAGE_INDEX: "message index",
    0x0A: "attachment index",
    0x0B: "statistics",
    0x08: "chunk index",
    0x0D: "metadata index",
    0x0E: "summary offset",
}
