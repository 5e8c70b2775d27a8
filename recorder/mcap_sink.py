"""The MCAP sink: every event as JSON on its topic's channel, plus Foxglove's views.

Byte-identical output for identical events: the header carries no time or host,
metadata and attachments carry no wall-clock value, schemas are encoded with
sorted keys and log time = publish time = the simulated time.

Crash safety: the header, schemas, channels, metadata and attachments are written
outside chunks and flushed at open; messages go into zstd chunks of
``chunk_size_bytes`` (uncompressed, default 1 MiB) and the stream is flushed after
each chunk. A killed process therefore loses at most the open chunk and the
summary; :func:`recorder.reader.open_recording` recovers the rest.
"""

from __future__ import annotations

import itertools
import os
import struct
from collections.abc import Mapping, Sequence
from typing import IO, Any, Final

import mcap
import msgspec
from mcap._chunk_builder import ChunkBuilder
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import MessageIndex
from mcap.writer import CompressionType, Writer
from oimi.pipeline.events import Event, LogEntries, Topic, WorldState
from oimi.pipeline.messages import FORMAT_VERSION
from oimi.recorder import foxglove
from oimi.recorder.errors import RecordingError
from oimi.recorder.scene import SceneGeometry
from oimi.recorder.topics import (
    FORMAT_VERSION_KEY,
    MESSAGE_ENCODING,
    METADATA_OIMI,
    SCENE_ATTACHMENT,
    SCHEMA_ENCODING,
    FoxgloveTopic,
    foxglove_schema,
    schema_data,
    schema_name,
)
from oimi.recorder.world_sampling import (
    DEFAULT_WORLD_EVERY_N_TICKS,
    WORLD_EVERY_KEY,
    WorldSampling,
)

LIBRARY: Final = f"oimi format {FORMAT_VERSION}, mcap-python {mcap.__version__}"
"""The header's library string: versions only, no time, no host."""
DEFAULT_CHUNK_SIZE_BYTES: Final = 1024 * 1024
DEFAULT_FOXGLOVE_EVERY_N_TICKS: Final = 5
"""Foxglove scene/tf every 5 ticks: 10 Hz at the default 50 Hz tick rate."""
Attachment = tuple[str, bytes]
"""``(name, data)``; the media type is guessed from the name's extension."""

_MEDIA_TYPES: Final = {
    ".toml": "application/toml",
    ".json": "application/json",
    ".txt": "text/plain",
    ".md": "text/markdown",
    ".lark": "text/plain",
}


def media_type(name: str) -> str:
    """The media type recorded for an attachment called ``name``."""
    return _MEDIA_TYPES.get(os.path.splitext(name)[1].lower(), "application/octet-stream")


class _FlushingStream:
    """Passes writes through and flushes after each one (the writer writes once per chunk)."""

    def __init__(self, stream: IO[bytes]) -> None:
        self._stream = stream

    def write(self, data: bytes) -> int:
        if not data:
            return 0
        written = self._stream.write(data)
        self._stream.flush()
        return written

    def tell(self) -> int:
        return self._stream.tell()

    def flush(self) -> None:
        self._stream.flush()


class McapSink:
    """Writes events to an MCAP file (or binary stream); a context manager; a ``Sink``.

    ``metadata`` records are written at open after the ``oimi`` record (which always
    holds ``format_version``); keys are sorted within each record. ``attachments``
    are ``(name, bytes)`` pairs with log and create time 0. ``scene`` draws the
    static arena for Foxglove and is attached as ``oimi/scene.json``.
    ``foxglove_every_n_ticks`` thins the scene and tf channels (0 turns the
    Foxglove views off); ``world_every_n_ticks`` thins ``/world/state`` as
    :class:`~recorder.world_sampling.WorldSampling` says (1 keeps every tick).
    """

    def __init__(
        self,
        path_or_stream: str | os.PathLike[str] | IO[bytes],
        *,
        metadata: Mapping[str, Mapping[str, str]] | None = None,
        attachments: Sequence[Attachment] = (),
        scene: SceneGeometry | None = None,
        foxglove_every_n_ticks: int = DEFAULT_FOXGLOVE_EVERY_N_TICKS,
        world_every_n_ticks: int = DEFAULT_WORLD_EVERY_N_TICKS,
        chunk_size_bytes: int = DEFAULT_CHUNK_SIZE_BYTES,
    ) -> None:
        self._sampling = WorldSampling(world_every_n_ticks)
        if foxglove_every_n_ticks < 0:
            raise RecordingError(
                f"foxglove_every_n_ticks must be >= 0, got {foxglove_every_n_ticks}"
            )
        is_path = isinstance(path_or_stream, str | os.PathLike)
        self._name = os.fspath(path_or_stream) if is_path else "<stream>"  # type: ignore[arg-type]
        if is_path:
            try:
                self._file: IO[bytes] | None = open(path_or_stream, "wb")  # noqa: SIM115
            except OSError as error:
                raise RecordingError(f"cannot write: {error.strerror}", source=self._name) from None
            stream: IO[bytes] = self._file
        else:
            self._file = None
            stream = path_or_stream
        self._every = foxglove_every_n_ticks
        self._closed = False
        self._encode = msgspec.json.Encoder().encode
        self._writer = Writer(
            _FlushingStream(stream),  # type: ignore[arg-type]
            chunk_size=chunk_size_bytes,
            compression=CompressionType.ZSTD,
        )
        self._messages = _MessageWriter(self._writer, chunk_size_bytes=chunk_size_bytes)
        self._writer.start(profile="", library=LIBRARY)
        self._channels: dict[str, int] = {}
        self._schemas: dict[tuple[str, bytes], int] = {}
        with _outside_chunks(self._writer):
            for topic in Topic:
                self._register(topic, schema_name(topic), schema_data(topic))
            if self._every:
                for fox in FoxgloveTopic:
                    self._register(fox, *foxglove_schema(fox))
        self._write_metadata(metadata or {})
        if scene is not None:
            attachments = [*attachments, (SCENE_ATTACHMENT, msgspec.json.encode(scene))]
        for name, data in attachments:
            self._writer.add_attachment(
                create_time=0, log_time=0, name=name, media_type=media_type(name), data=data
            )
        self._writer.flush()
        self._views = foxglove.Views(scene, foxglove_every_n_ticks)

    def _register(self, topic: str, name: str, data: bytes) -> None:
        """A channel for ``topic``; channels of the same schema share its one record."""
        schema_id = self._schemas.get((name, data))
        if schema_id is None:
            schema_id = self._writer.register_schema(name=name, encoding=SCHEMA_ENCODING, data=data)
            self._schemas[name, data] = schema_id
        self._channels[topic] = self._writer.register_channel(
            topic=topic, message_encoding=MESSAGE_ENCODING, schema_id=schema_id
        )

    def _write_metadata(self, metadata: Mapping[str, Mapping[str, str]]) -> None:
        oimi = {
            **metadata.get(METADATA_OIMI, {}),
            FORMAT_VERSION_KEY: str(FORMAT_VERSION),
            WORLD_EVERY_KEY: str(self._sampling.every_n_ticks),
        }
        records = {METADATA_OIMI: oimi, **{k: v for k, v in metadata.items() if k != METADATA_OIMI}}
        for name, record in records.items():
            self.add_metadata(name, record)

    def add_metadata(self, name: str, record: Mapping[str, str]) -> None:
        """Write one metadata record now, keys sorted: those given at open, or one written
        later (a live session's ``session`` record again at its end, with its true length).
        Readers that key records by name see the last record of a name."""
        if self._closed:
            raise RecordingError(f"add_metadata({name!r}) after close()", source=self._name)
        bad = [k for k, v in record.items() if not isinstance(k, str) or not isinstance(v, str)]
        if bad:
            raise RecordingError(
                f"metadata record {name!r}: keys and values must be strings, not at {bad[0]!r}",
                source=self._name,
            )
        self._writer.add_metadata(name, dict(sorted(record.items())))

    # ---------------------------------------------------------------- Sink

    def record(self, topic: Topic, time_ns: int, message: Event) -> None:
        """Write one event at simulated time ``time_ns`` (and its Foxglove views, if due)."""
        if self._closed:
            raise RecordingError(f"record({topic}) after close()", source=self._name)
        # Exact classes (nothing derives from them): ``isinstance`` on a Struct class that
        # misses goes through msgspec's metaclass, at every event.
        kind = type(message)
        if kind is WorldState:
            if self._sampling.keep(time_ns, message):
                self._add(topic, time_ns, self._encode(message))
            if self._every:
                for view_topic, view in self._views.world(message, time_ns):
                    self._add(view_topic, time_ns, self._encode(view))
            return
        self._add(topic, time_ns, self._encode(message))
        if self._every and kind is LogEntries:
            for log in foxglove.log_messages(message, time_ns):
                self._add(FoxgloveTopic.LOG, time_ns, self._encode(log))

    def add_encoded(self, topic: str, time_ns: int, payload: bytes) -> None:
        """Write one message already encoded (a recording's payload re-written) on one of
        the sink's topics (``Topic`` or, with views on, ``FoxgloveTopic``)."""
        if self._closed:
            raise RecordingError(f"add_encoded({topic}) after close()", source=self._name)
        self._add(topic, time_ns, payload)

    def _add(self, topic: str, time_ns: int, payload: bytes) -> None:
        try:
            channel = self._channels[topic]
        except KeyError:
            raise RecordingError(f"unknown topic {topic!r}", source=self._name) from None
        self._messages.add(channel, time_ns, payload)

    # ----------------------------------------------------------- lifecycle

    def close(self) -> None:
        """Write the session's last world state if it was not kept, the last chunk and the
        summary; closes a file it opened. Idempotent."""
        if self._closed:
            return
        self._closed = True
        try:
            if (last := self._sampling.last()) is not None:
                self._add(Topic.WORLD_STATE, last[0], self._encode(last[1]))
            self._messages.flush()
            self._writer.finish()
        finally:
            if self._file is not None:
                self._file.close()

    def __enter__(self) -> McapSink:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


_MESSAGE_PREFIX: Final = struct.Struct("<BQHIQQ")
"""A Message record's opcode and length, then channel id, sequence, log and publish time."""
_MESSAGE_PREFIX_BYTES: Final = _MESSAGE_PREFIX.size
_MESSAGE_FIELDS_BYTES: Final = 2 + 4 + 8 + 8
_MESSAGE_OPCODE: Final = Opcode.MESSAGE
"""Read at every message: a global, not the enum class's slow attribute path."""
_STATISTICS: Final = "_Writer__statistics"
_FINALIZE_CHUNK: Final = "_Writer__finalize_chunk"


class _MessageWriter:
    """Adds messages exactly as mcap's ``Writer.add_message`` does, in far fewer calls.

    mcap 1.6 builds a ``Message`` dataclass per message and writes it field by
    field through its record builder (about twenty Python calls), and updates the
    chunk's and the file's times, counts and message index at each. This packs each
    record in one go into the open chunk's bytes and hands them, with the chunk's
    times, counts and index, to the writer's chunk builder and statistics once per
    chunk (when it is full, and at :meth:`flush`, before the writer finishes), so the
    file's bytes do not change (the recorder tests and the golden recordings compare
    them). It relies on the writer's private chunk builder, statistics and chunk
    finaliser, like ``_outside_chunks``; without them it falls back to ``add_message``.
    """

    def __init__(self, writer: Writer, *, chunk_size_bytes: int) -> None:
        self._writer = writer
        self._chunk_size = chunk_size_bytes
        self._fast = all(
            hasattr(writer, name) for name in (_outside_chunks._ATTR, _STATISTICS, _FINALIZE_CHUNK)
        ) and isinstance(getattr(writer, _outside_chunks._ATTR, None), ChunkBuilder)
        if self._fast:
            self._builder = ChunkBuilder()
            setattr(writer, _outside_chunks._ATTR, self._builder)
            self._statistics: Any = getattr(writer, _STATISTICS)
            self._finalize_chunk = getattr(writer, _FINALIZE_CHUNK)
        self._records: list[bytes] = []
        """The open chunk's message records, not yet in the chunk builder: each record's
        prefix and payload as they came (joined once, at :meth:`flush`; a growing
        ``bytearray`` was copied again at each of its reallocations)."""
        self._size = 0
        """How many bytes ``_records`` holds."""
        self._index: dict[int, list[tuple[int, int]]] = {}
        """Each channel's ``(log time, offset)`` entries in the open chunk."""
        self._count = 0
        self._start = self._end = 0
        self._base = 0
        """Where the records begin in the chunk builder's (what it held before them)."""

    def add(self, channel: int, time_ns: int, payload: bytes) -> None:
        """One message with log time = publish time = ``time_ns`` and sequence 0 (MCAP's
        "not used": a message's place on its channel is its place in the file; a counter
        there cost 3 % of a recording, breaking zstd's matches in every record's header)."""
        if not self._fast:
            self._writer.add_message(
                channel_id=channel,
                log_time=time_ns,
                publish_time=time_ns,
                data=payload,
                sequence=0,
            )
            return
        if self._count == 0:
            self._base = self._builder.count
            self._start = time_ns
        elif time_ns < self._start:
            self._start = time_ns
        if time_ns > self._end:
            self._end = time_ns
        self._count += 1
        entries = self._index.get(channel)
        if entries is None:
            entries = self._index[channel] = []
        offset = self._base + self._size
        entries.append((time_ns, offset))
        size = len(payload)
        records = self._records
        records.append(
            _MESSAGE_PREFIX.pack(
                _MESSAGE_OPCODE, _MESSAGE_FIELDS_BYTES + size, channel, 0, time_ns, time_ns
            )
        )
        records.append(payload)
        self._size += _MESSAGE_PREFIX_BYTES + size
        if self._base + self._size > self._chunk_size:
            self.flush()
            self._finalize_chunk()

    def flush(self) -> None:
        """Hand the open chunk's messages to the writer's chunk builder and statistics
        (what ``add_message`` would have done at each of them)."""
        if not self._count:
            return
        statistics, chunk = self._statistics, self._builder
        _widen(statistics, statistics.message_count == 0, self._start, self._end)
        _widen(chunk, chunk.num_messages == 0, self._start, self._end)
        counts = statistics.channel_message_counts
        for channel, entries in self._index.items():
            counts[channel] += len(entries)  # in the order first written: it is recorded
            index = _MessageIndex(channel_id=channel, records=[])
            chunk.message_indices.setdefault(channel, index).records += entries
        statistics.message_count += self._count
        chunk.num_messages += self._count
        chunk.record_writer.write(b"".join(self._records))
        self._records = []
        self._size = 0
        self._index = {}
        self._count = self._end = 0


def _widen(target: Any, empty: bool, start: int, end: int) -> None:
    """Make ``target``'s message time range (the file's or a chunk's) cover ``start`` to
    ``end`` (an empty one takes ``start`` as it is)."""
    if empty or start < target.message_start_time:
        target.message_start_time = start
    target.message_end_time = max(target.message_end_time, end)


class _MessageIndex(MessageIndex):
    """mcap's message index record, its entries packed at once rather than two calls each."""

    def write(self, stream: RecordBuilder) -> None:
        entries = self.records
        stream.start_record(Opcode.MESSAGE_INDEX)
        stream.write2(self.channel_id)
        stream.write4(len(entries) * 16)
        stream.write(struct.pack(f"<{2 * len(entries)}Q", *itertools.chain.from_iterable(entries)))
        stream.finish_record()


class _outside_chunks:
    """Registers schemas and channels straight into the data section, not the first chunk.

    mcap's ``Writer`` keeps them in its chunk builder until the first chunk is
    full, so a killed run would lose them; this detaches the builder meanwhile.
    """

    _ATTR: Final = "_Writer__chunk_builder"

    def __init__(self, writer: Writer) -> None:
        self._writer = writer
        self._builder: Any = None

    def __enter__(self) -> None:
        if hasattr(self._writer, self._ATTR):
            self._builder = getattr(self._writer, self._ATTR)
            setattr(self._writer, self._ATTR, None)

    def __exit__(self, *exc_info: object) -> None:
        if self._builder is not None:
            setattr(self._writer, self._ATTR, self._builder)
