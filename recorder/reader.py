"""Reading recordings back: metadata, attachments, counts and a stream of typed events.

A damaged or truncated file (a killed run) is read up to its last complete chunk
and described by a :class:`RecoveryReport`; a file that is not MCAP at all, or
written by another format version, raises :class:`RecordingError`.
"""

from __future__ import annotations

import contextlib
import os
import struct
import zlib
from collections.abc import Iterable, Iterator
from functools import cache
from typing import IO, Final, NamedTuple

import msgspec
import zstandard
from mcap.exceptions import EndOfFile, InvalidMagic, McapError
from mcap.reader import SeekingReader
from mcap.records import AttachmentIndex
from oimi.pipeline.events import TOPIC_TYPES, Event, MapDelta, Topic
from oimi.pipeline.mapdeltas import apply_delta
from oimi.pipeline.messages import READ_FORMAT_VERSIONS, WorldMap
from oimi.recorder.errors import RecordingError
from oimi.recorder.metadata import RecordingMetadata
from oimi.recorder.scan import ChunkScan, Damage, RecoveryReport, attachment
from oimi.recorder.topics import FORMAT_VERSION_KEY, METADATA_OIMI

_READ_ERRORS: Final = (
    McapError,
    ValueError,
    OverflowError,
    struct.error,
    zstandard.ZstdError,
    EOFError,
    KeyError,
)
"""What a damaged summary makes mcap's indexed reader raise (``EndOfFile``, CRC mismatch,
bad offsets...): the file is then read record by record instead."""


class _Bounded:
    """A file for mcap's indexed reader: a read longer than what is left of the file
    raises ``EndOfFile`` at once instead of allocating a damaged length's bytes."""

    def __init__(self, stream: IO[bytes]) -> None:
        self.stream = stream
        self.size = os.fstat(stream.fileno()).st_size

    def read(self, size: int = -1) -> bytes:
        if size > self.size - self.stream.tell():
            raise EndOfFile()
        return self.stream.read(size)

    def seek(self, offset: int, whence: int = 0) -> int:
        return self.stream.seek(offset, whence)

    def tell(self) -> int:
        return self.stream.tell()

    def seekable(self) -> bool:
        return True


class _Stamp(msgspec.Struct):
    """The two fields every event starts with (the rest is skipped unparsed)."""

    tick: int
    time_ms: int


_stamp_decoder: Final = msgspec.json.Decoder(_Stamp)


@cache
def _decoder(topic: Topic) -> msgspec.json.Decoder[Event]:
    return msgspec.json.Decoder(TOPIC_TYPES[topic])


class RecordedMessage(msgspec.Struct, frozen=True, kw_only=True):
    """One recorded event, its payload still encoded (``decoded()`` builds the Struct)."""

    topic: Topic
    tick: int
    time_ns: int
    """Log time: the simulated time, ns."""
    sequence: int
    """Index of the message on its channel, from 0."""
    payload_bytes: bytes
    source: str
    """The file it was read from (named by the error of a payload that does not decode)."""

    def decoded(self) -> Event:
        """The payload as its topic's Struct (``pipeline.events.TOPIC_TYPES``)."""
        try:
            return _decoder(self.topic).decode(self.payload_bytes)
        except msgspec.DecodeError as error:
            raise RecordingError(
                f"{self.topic} message {self.sequence} (tick {self.tick}): {error}",
                source=self.source,
            ) from None


class RecordedMap(NamedTuple):
    """The full map as of one ``/map`` message (``Recording.maps()``)."""

    tick: int
    time_ms: int
    map: WorldMap
    """Rebuilt from the keyframe before it and the deltas since; shares its unchanged
    parts with the previous one: read-only."""


_map_decoder: Final = msgspec.json.Decoder(MapDelta)


class Recording:
    """An opened recording; :meth:`iter_messages` re-reads the file on each call."""

    def __init__(
        self,
        path: str,
        *,
        metadata: dict[str, dict[str, str]],
        attachments: dict[str, bytes],
        summary: dict[str, int],
        recovery: RecoveryReport | None,
        end_ns: int | None = None,
    ) -> None:
        self.path = path
        self.metadata = metadata
        """Metadata records as read: name -> key -> value, in file order."""
        self.meta = RecordingMetadata.from_records(metadata, source=path)
        """The metadata records, typed (the one reading of them)."""
        self.attachments = attachments
        """Attachment name -> bytes, in file order."""
        self.summary = summary
        """Message count per topic (every channel, Foxglove's included), in channel order."""
        self.recovery = recovery
        """Set when the file is damaged: what could be read (updated by ``iter_messages``)."""
        self.end_ns = end_ns
        """The last message's log time, from the summary's statistics (None without a
        usable summary): where the session ends, without reading its messages."""

    @property
    def format_version(self) -> int:
        return int(self.meta.oimi.format_version or "0")

    def iter_messages(
        self, topics: Iterable[Topic | str] | None = None, *, check_indexes: bool = False
    ) -> Iterator[RecordedMessage]:
        """Our topics' messages in file order (= simulated-time order), streamed.

        ``topics`` limits the topics (all of ``Topic`` by default). On a damaged
        file iteration ends at the damage and :attr:`recovery` says where and why;
        with ``check_indexes`` a message index that does not list its chunk's messages
        is damage too (``oimi info``: what a viewer that seeks reads by).
        """
        wanted = _wanted_topics(topics, self.path)
        with _open(self.path) as stream:
            scan = ChunkScan(
                stream, frozenset(t.value for t in wanted), check_indexes=check_indexes
            )
            counts: dict[str, int] = {}
            topic_of = {t.value: t for t in wanted}  # (an enum call per message is slow)
            try:
                for topic, _, log_time_ns, data in scan.messages():
                    sequence = counts.get(topic, 0)  # its place on its channel (the record: 0)
                    counts[topic] = sequence + 1
                    try:
                        tick = _stamp_decoder.decode(data).tick
                    except msgspec.DecodeError as error:
                        scan.damage = Damage(
                            scan.good_byte,
                            f"chunk: {topic} message {sequence} is not a recorded event: {error}",
                        )
                        break
                    yield RecordedMessage(
                        topic=topic_of[topic],
                        tick=tick,
                        time_ns=log_time_ns,
                        sequence=sequence,
                        payload_bytes=data,
                        source=self.path,
                    )
            except ValueError as error:  # bad magic: open_recording has refused such files
                raise RecordingError(str(error), source=self.path) from None
            if scan.damage is not None:
                self.recovery = scan.report()

    def maps(self) -> Iterator[RecordedMap]:
        """The full map after each ``/map`` message, in order: keyframes and deltas applied
        (``pipeline.mapdeltas.apply_delta``), the one way to read maps back. A delta
        that cannot be applied raises :class:`RecordingError` naming the message."""
        world_map: WorldMap | None = None
        repeats = self.format_version >= 9
        for message in self.iter_messages((Topic.MAP,)):
            try:
                delta = _map_decoder.decode(message.payload_bytes)
                world_map = apply_delta(world_map, delta, repeats=repeats)
            except (msgspec.DecodeError, ValueError) as error:
                raise RecordingError(
                    f"/map message {message.sequence} (tick {message.tick}): {error}",
                    source=self.path,
                ) from None
            yield RecordedMap(delta.tick, delta.time_ms, world_map)

    def map_at(self, tick: int) -> WorldMap | None:
        """The map as it was at the end of ``tick`` (the last ``/map`` message at or before
        it, rebuilt); None before the first."""
        found = None
        with contextlib.closing(self.maps()) as maps:
            for recorded in maps:
                if recorded.tick > tick:
                    break
                found = recorded.map
        return found


_TOPIC_NAMES: Final = frozenset(t.value for t in Topic)


def _wanted_topics(topics: Iterable[Topic | str] | None, path: str) -> frozenset[Topic]:
    if topics is None:
        return frozenset(Topic)
    wanted = []
    for topic in topics:
        if topic not in _TOPIC_NAMES:
            known = ", ".join(t.value for t in Topic)
            raise RecordingError(f"unknown topic {topic!r}; known topics: {known}", source=path)
        wanted.append(Topic(topic))
    return frozenset(wanted)


def _open(path: str) -> IO[bytes]:
    try:
        return open(path, "rb")
    except OSError as error:
        raise RecordingError(f"cannot read: {error.strerror}", source=path) from None


def open_recording(path: str | os.PathLike[str]) -> Recording:
    """Open an oimi MCAP recording: metadata, attachments and counts are read now.

    Raises :class:`RecordingError` when the file cannot be read, is empty or not
    MCAP, has no ``oimi`` metadata record, or has another format version.
    """
    name = os.fspath(path)
    with _open(name) as stream:
        size = os.fstat(stream.fileno()).st_size
        if size == 0:
            raise RecordingError("empty file, not an MCAP recording", source=name)
        recording = _read_indexed(stream, name) or _read_streamed(stream, name)
        damage = None if recording.recovery else _summary_damage(stream)
    if damage is not None:
        recording.recovery = RecoveryReport(
            messages=sum(recording.summary.values()),
            stopped_at_byte=damage.at,
            file_size=size,
            reason=damage.what,
        )
    _check_version(recording)
    return recording


def _read_indexed(stream: IO[bytes], path: str) -> Recording | None:
    """The fast way, through the summary section; None when the file has none usable."""
    try:
        reader = SeekingReader(_Bounded(stream), validate_crcs=True)
    except InvalidMagic:
        raise RecordingError("not an MCAP file (bad magic bytes)", source=path) from None
    except (*_READ_ERRORS, OSError):
        stream.seek(0)
        return None
    try:
        summary = reader.get_summary()
        if summary is None or summary.statistics is None or _summary_damage(stream):
            return None
        counts = summary.statistics.channel_message_counts
        return Recording(
            path,
            metadata={m.name: dict(m.metadata) for m in reader.iter_metadata()},
            attachments=_attachments(stream, summary.attachment_indexes),
            summary={c.topic: counts.get(c.id, 0) for c in summary.channels.values()},
            recovery=None,
            end_ns=summary.statistics.message_end_time
            if summary.statistics.message_count
            else None,
        )
    except (*_READ_ERRORS, OSError):
        return None
    finally:
        stream.seek(0)


_FOOTER_TAIL: Final = 9 + 8 + 8 + 4 + 8
"""A file's last bytes: the footer record (opcode, length, summary start, summary offset
start, summary CRC) and the closing magic."""


def _summary_damage(stream: IO[bytes]) -> Damage | None:
    """Damage when the summary section does not match its CRC in the footer (mcap's reader
    does not check it: counts and indexes read from a changed summary would be believed);
    None when it matches or the file has no footer (the scan reports that)."""
    size = os.fstat(stream.fileno()).st_size
    if size < _FOOTER_TAIL + 8:
        return None
    stream.seek(size - _FOOTER_TAIL)
    footer = stream.read(_FOOTER_TAIL)
    if footer[0] != 0x02:
        return None
    summary_start, _, crc = struct.unpack_from("<QQI", footer, 9)
    if crc == 0:  # not computed by the writer
        return None
    at = size - _FOOTER_TAIL
    if summary_start and 8 <= summary_start <= at:
        stream.seek(summary_start)
        if zlib.crc32(footer[:25], zlib.crc32(stream.read(at - summary_start))) == crc:
            return None
        at = summary_start
    return Damage(at, "summary: CRC mismatch, so its counts and indexes are not used")


def _attachments(stream: IO[bytes], indexes: list[AttachmentIndex]) -> dict[str, bytes]:
    """The attachments the summary points at, each record's lengths and CRC checked
    (mcap's ``iter_attachments`` checks neither); ValueError when one is damaged."""
    size = os.fstat(stream.fileno()).st_size
    found = {}
    for index in indexes:
        if not 9 <= index.length <= size - index.offset:
            raise ValueError(f"attachment index of {index.name!r} points past the end")
        stream.seek(index.offset + 9)  # after the record's opcode and length
        record = attachment(stream.read(index.length - 9))
        found[record.name] = record.data
    return found


def _read_streamed(stream: IO[bytes], path: str) -> Recording:
    """One pass over every record: for files without a (readable) summary."""
    scan = ChunkScan(stream, frozenset(), keep_records=True)
    try:
        for _ in scan.messages():
            pass
    except ValueError as error:  # bad magic
        raise RecordingError(str(error), source=path) from None
    report = scan.report()
    if report is not None and not scan.metadata and scan.count == 0:
        raise RecordingError(f"unreadable MCAP file: {report}", source=path)
    return Recording(
        path,
        metadata=scan.metadata,
        attachments=scan.attachments,
        summary=scan.counts,
        recovery=report,
    )


def _check_version(recording: Recording) -> None:
    version = recording.meta.oimi.format_version
    if version is None:
        raise RecordingError(
            f"not an oimi recording: no {METADATA_OIMI!r} metadata record with"
            f" {FORMAT_VERSION_KEY!r}",
            source=recording.path,
        )
    if version not in [str(v) for v in READ_FORMAT_VERSIONS]:
        readable = ", ".join(map(str, READ_FORMAT_VERSIONS))
        raise RecordingError(
            f"recorded with format version {version}, but this oimi reads format versions"
            f" {readable}",
            source=recording.path,
        )
