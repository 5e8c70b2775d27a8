"""A fast, streaming pass over an MCAP file's messages, for replay and analysis.

mcap's own stream reader builds an object per record; this scanner walks the
records itself: it reads channels, decompresses each chunk once (checking its
CRC) and slices the message records out of it, skipping message indexes and the
summary. It stops quietly at the first damage and says where and why, so that a
truncated recording is read up to its last complete chunk.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Iterator
from io import BytesIO
from typing import IO, Final, NamedTuple

import zstandard
from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.records import Channel

MAGIC: Final = b"\x89MCAP0\r\n"
_FOOTER: Final = 0x02
_CHANNEL: Final = 0x04
_MESSAGE: Final = 0x05
_CHUNK: Final = 0x06
_DATA_END: Final = 0x0F
_RECORD_HEADER: Final = struct.Struct("<BQ")
_U64: Final = struct.Struct("<Q")
_CHUNK_HEADER: Final = struct.Struct("<QQQII")
"""Chunk: start and end time, uncompressed size and CRC, compression name length."""
_MESSAGE_HEADER: Final = struct.Struct("<HIQQ")
"""Message: channel id, sequence, log time, publish time."""
READ_ERRORS: Final = (
    McapError,
    ValueError,
    struct.error,
    zstandard.ZstdError,
    EOFError,
    KeyError,
    UnicodeDecodeError,
)


class Scanned(NamedTuple):
    """One message of a wanted topic: where it was logged and its payload bytes."""

    topic: str
    sequence: int
    log_time_ns: int
    data: bytes


class ChunkScan:
    """Streams the messages of the ``wanted`` topics in file order.

    After iteration, ``error`` is None for a complete file, else what stopped the
    scan; ``good_byte`` is where the last complete record ended and ``count`` the
    number of messages (of every topic) in the complete chunks read.
    """

    def __init__(self, stream: IO[bytes], wanted: frozenset[str]) -> None:
        self.stream = stream
        self.wanted = wanted
        self.channels: dict[int, str] = {}
        self.error: Exception | None = None
        self.count = 0
        self.good_byte = 0
        self._zstd = zstandard.ZstdDecompressor()

    def messages(self) -> Iterator[Scanned]:
        read = self.stream.read
        if read(len(MAGIC)) != MAGIC:
            raise ValueError("not an MCAP file (bad magic bytes)")
        self.good_byte = len(MAGIC)
        try:
            while True:
                head = read(_RECORD_HEADER.size)
                if not head:
                    raise EOFError("the file ends without its footer")
                opcode, length = _RECORD_HEADER.unpack(head)
                if opcode in (_FOOTER, _DATA_END):
                    return
                body = read(length)
                if len(body) != length:
                    raise EOFError("the file ends inside a record")
                if opcode == _CHANNEL:
                    self._channel(body)
                elif opcode == _CHUNK:
                    yield from self._chunk(body)
                self.good_byte += _RECORD_HEADER.size + length
        except READ_ERRORS as error:
            self.error = error

    def _channel(self, body: bytes) -> None:
        record = Channel.read(ReadDataStream(BytesIO(body)))
        if record.topic in self.wanted:
            self.channels[record.id] = record.topic

    def _chunk(self, body: bytes) -> list[Scanned]:
        _, _, size, crc, name_length = _CHUNK_HEADER.unpack_from(body)
        at = _CHUNK_HEADER.size
        compression = body[at : at + name_length].decode()
        at += name_length
        (records_length,) = _U64.unpack_from(body, at)
        at += _U64.size
        data = self._decompress(body[at : at + records_length], compression, size, crc)
        channels, header, message = self.channels, _RECORD_HEADER, _MESSAGE_HEADER
        offset, end = 0, len(data)
        found, count = [], 0
        while offset < end:
            opcode, length = header.unpack_from(data, offset)
            start = offset + header.size
            offset = start + length
            if opcode == _MESSAGE:
                count += 1
                channel, sequence, log_time, _ = message.unpack_from(data, start)
                topic = channels.get(channel)
                if topic is not None:
                    payload = data[start + message.size : offset]
                    found.append(Scanned(topic, sequence, log_time, payload))
            elif opcode == _CHANNEL:
                self._channel(data[start:offset])
        if offset != end:
            raise ValueError("chunk records overrun the chunk")
        self.count += count
        return found

    def _decompress(self, data: bytes, compression: str, size: int, crc: int) -> bytes:
        if compression == "zstd":
            data = self._zstd.decompress(data, max_output_size=size)
        elif compression != "":
            raise ValueError(f"unsupported chunk compression {compression!r}")
        if crc and zlib.crc32(data) != crc:
            raise ValueError("chunk CRC mismatch")
        return data
