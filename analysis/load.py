"""A recording's topics as polars DataFrames, decoded in bulk.

The chunks are decompressed and split by channel in one pass; each topic's JSON
payloads are joined into one NDJSON buffer and read by ``polars.read_ndjson``
with a schema derived from the topic's msgspec Struct; lists of items
(decisions, commands, progress items, log entries, humans) are exploded and
their structs unnested with polars, never row by row in Python.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterable, Iterator
from typing import Final

import msgspec
import polars as pl
import pyarrow as pa
import pyarrow.json as pa_json
from oimi.analysis.stream import FOLDED, STREAMED, Streamed, StreamFolder
from oimi.pipeline.events import TOPIC_TYPES, Topic
from oimi.pipeline.messages import WorldMap
from oimi.recorder.errors import RecordingError
from oimi.recorder.metadata import RecordingMetadata
from oimi.recorder.reader import Recording, RecoveryReport, open_recording
from oimi.recorder.scan import ChunkScan

TIME: Final = "time"
"""The simulated time as a ``pl.Duration("ms")`` column (beside ``time_ms``)."""

DEFAULT_TOPICS: Final = tuple(t for t in Topic if t is not Topic.MAP)
"""What is loaded unless asked: every topic but ``/map`` (large, and no metric needs it).
Asked for, ``/map`` is one row per ``/map`` message holding the *full* map as of it
(:class:`MapRow`, rebuilt from keyframes and deltas by ``Recording.maps()``)."""

LIGHT_TOPICS: Final = tuple(
    t for t in DEFAULT_TOPICS if t.value not in STREAMED and t is not Topic.SENSOR_UPDATES
)
"""The topics loaded as tables when streaming: their size grows with what happens, not with
the ticks (no metric reads ``/sensors/updates``)."""


class AnalysisWarning(UserWarning):
    """A recording could be analysed only in part (damaged or truncated file)."""


# ------------------------------------------------------------------------- schemas


def polars_dtype(info: msgspec.inspect.Type) -> pl.DataType | None:
    """The polars type of a msgspec type; None for what NDJSON reading cannot type
    (free-keyed dicts): such fields are left out of the frame. A union of tagged Structs
    (the operator's commands) is one struct of the tag and every member's fields, null
    where a member has no such field."""
    match info:
        case msgspec.inspect.BoolType():
            return pl.Boolean()
        case msgspec.inspect.IntType():
            return pl.Int64()
        case msgspec.inspect.FloatType():
            return pl.Float64()
        case msgspec.inspect.StrType():
            return pl.String()
        case msgspec.inspect.EnumType():
            return pl.String() if issubclass(info.cls, str) else pl.Int64()
        case msgspec.inspect.LiteralType():
            return pl.String() if isinstance(info.values[0], str) else pl.Int64()
        case msgspec.inspect.VarTupleType() | msgspec.inspect.ListType():
            inner = polars_dtype(info.item_type)
            return None if inner is None else pl.List(inner)
        case msgspec.inspect.TupleType():
            inner = [polars_dtype(t) for t in info.item_types]
            same = inner and all(i is not None and i == inner[0] for i in inner)
            return pl.List(inner[0]) if same else None  # type: ignore[arg-type]
        case msgspec.inspect.UnionType() if all(_tagged(t) for t in info.types):
            return pl.Struct(_union_schema(info.types))  # type: ignore[arg-type]
        case msgspec.inspect.UnionType() if info.includes_none and len(info.types) == 2:
            (inner,) = [t for t in info.types if not isinstance(t, msgspec.inspect.NoneType)]
            return polars_dtype(inner)
        case msgspec.inspect.StructType():
            if info.cls.__struct_config__.tag is not None:
                return None
            return pl.Struct(struct_schema(info.cls))
    return None


def _tagged(info: msgspec.inspect.Type) -> bool:
    return isinstance(info, msgspec.inspect.StructType) and info.tag is not None


def _union_schema(members: Iterable[msgspec.inspect.StructType]) -> dict[str, pl.DataType]:
    """The tag first, then each member's fields in the union's order (first type wins)."""
    schema: dict[str, pl.DataType] = {}
    for member in members:
        schema.setdefault(member.tag_field, pl.String())  # type: ignore[arg-type]
        for name, dtype in struct_schema(member.cls).items():
            schema.setdefault(name, dtype)
    return schema


def struct_schema(cls: type[msgspec.Struct]) -> dict[str, pl.DataType]:
    """A Struct's fields as a polars schema (fields polars cannot type are left out)."""
    info = msgspec.inspect.type_info(cls)
    assert isinstance(info, msgspec.inspect.StructType)
    schema = {}
    for field in info.fields:
        dtype = polars_dtype(field.type)
        if dtype is not None:
            schema[field.encode_name] = dtype
    return schema


_ARROW_SCALARS: Final = (
    {}
    if pa is None
    else {
        pl.Boolean: pa.bool_(),
        pl.Int64: pa.int64(),
        pl.Float64: pa.float64(),
        pl.String: pa.string(),
    }
)

# ----------------------------------------------------------------------- shaping

_ITEMS: Final[dict[Topic, str]] = {
    Topic.SENSOR_UPDATES: "updates",
    Topic.OPERATOR_COMMANDS: "commands",
    Topic.RULE_DECISIONS: "decisions",
    Topic.ACTUATOR_COMMANDS: "commands",
    Topic.LOG: "entries",
}
"""Topics whose frame has one row per item of this list field (the message's own
fields, tick and time, repeated)."""

_TABLE_ITEMS: Final = {
    "/reader/progress/items": (Topic.READER_PROGRESS, "items"),
    "/world/state/humans": (Topic.WORLD_STATE, "humans"),
    "/world/state/objects": (Topic.WORLD_STATE, "objects"),
    "/operator/state/replies": (Topic.OPERATOR_STATE, "replies"),
}
"""Extra tables: one row per item of a list whose message also matters per row."""


def _with_time(frame: pl.DataFrame) -> pl.DataFrame:
    """Adds ``time`` (a duration) after ``tick`` and ``time_ms``."""
    return frame.select(
        "tick",
        "time_ms",
        pl.col("time_ms").cast(pl.Duration("ms")).alias(TIME),
        pl.exclude("tick", "time_ms"),
    )


def _explode(frame: pl.DataFrame, column: str) -> pl.DataFrame:
    """One row per item of a list-of-structs column, the struct's fields as columns."""
    keep = [c for c in ("tick", "time_ms", TIME) if c in frame.columns]
    items = frame.select(*keep, column).explode(column).drop_nulls(column)
    inner = items.schema[column]
    if isinstance(inner, pl.Struct):
        clash = {f.name for f in inner.fields} & set(keep)
        items = items.with_columns(
            pl.col(column).struct.rename_fields(
                [f"{column}_{f.name}" if f.name in clash else f.name for f in inner.fields]
            )
        ).unnest(column)
    return items


def _flatten_world(frame: pl.DataFrame) -> pl.DataFrame:
    """``/world/state`` per recorded state: the robot's fields as ``robot_*``, the LED as
    r/g/b."""
    robot = pl.col("robot")
    fields = [f.name for f in frame.schema["robot"].fields]  # type: ignore[union-attr]
    return frame.with_columns(
        *[robot.struct.field(f).alias(f"robot_{f}") for f in fields if f not in ("id", "kind")],
        pl.col("led").list.get(0, null_on_oob=True).alias("led_r"),
        pl.col("led").list.get(1, null_on_oob=True).alias("led_g"),
        pl.col("led").list.get(2, null_on_oob=True).alias("led_b"),
        pl.col("contacts").list.len().alias("contact_count"),
    ).drop("robot", "humans", "objects", "led")


def _shape(topic: Topic, frame: pl.DataFrame) -> dict[str, pl.DataFrame]:
    frame = _with_time(frame)
    tables: dict[str, pl.DataFrame] = {}
    for name, (source, column) in _TABLE_ITEMS.items():
        if source is topic:
            tables[name] = _explode(frame, column)
    if topic in _ITEMS:
        tables[topic.value] = _explode(frame, _ITEMS[topic])
    elif topic is Topic.WORLD_STATE:
        tables[topic.value] = _flatten_world(frame)
    elif topic is Topic.READER_PROGRESS:
        tables[topic.value] = frame.drop("items")
    else:
        tables[topic.value] = frame
    return tables


class MapRow(WorldMap, kw_only=True):
    """A row of the ``/map`` table: the full map after one ``/map`` message."""

    tick: int
    time_ms: int


def topic_schema(topic: Topic) -> dict[str, pl.DataType]:
    """The frame's columns for a topic's JSON rows (``/map``: :class:`MapRow`'s)."""
    return struct_schema(MapRow if topic is Topic.MAP else TOPIC_TYPES[topic])


def _map_payloads(recording: Recording) -> list[bytes]:
    """Each full map rebuilt from ``/map`` (``Recording.maps()``) as a :class:`MapRow`."""
    return [
        msgspec.json.encode(MapRow(tick=tick, time_ms=time_ms, **msgspec.structs.asdict(m)))
        for tick, time_ms, m in recording.maps()
    ]


def empty_tables(topics: Iterable[Topic] = DEFAULT_TOPICS) -> dict[str, pl.DataFrame]:
    """The tables of topics without messages: the right columns, no rows."""
    tables = {}
    for topic in topics:
        tables.update(_shape(topic, pl.DataFrame(schema=topic_schema(topic))))
    return tables


def _arrow_type(dtype: pl.DataType) -> pa.DataType:
    if isinstance(dtype, pl.List):
        return pa.list_(_arrow_type(dtype.inner))
    if isinstance(dtype, pl.Struct):
        return pa.struct([(f.name, _arrow_type(f.dtype)) for f in dtype.fields])
    return _ARROW_SCALARS[dtype.base_type()]


def read_payloads(topic: Topic, payloads: list[bytes]) -> pl.DataFrame:
    """One topic's JSON payloads as one frame of its Struct's fields (NDJSON read in bulk:
    pyarrow's JSON reader with the derived schema, several times faster than
    ``pl.read_ndjson`` on nested messages)."""
    schema = topic_schema(topic)
    if not payloads:
        return pl.DataFrame(schema=schema)
    buffer = b"\n".join(payloads)
    options = pa_json.ParseOptions(
        explicit_schema=pa.schema([(k, _arrow_type(v)) for k, v in schema.items()]),
        unexpected_field_behavior="ignore",
    )
    block = max(1 << 20, max(len(p) for p in payloads) + 1)
    table = pa_json.read_json(
        pa.BufferReader(buffer),
        read_options=pa_json.ReadOptions(block_size=block),
        parse_options=options,
    )
    return pl.from_arrow(table)  # type: ignore[return-value]


def payloads_to_tables(topic: Topic, payloads: list[bytes]) -> dict[str, pl.DataFrame]:
    """One topic's JSON payloads -> its tables (the topic's, and its exploded lists')."""
    return _shape(topic, read_payloads(topic, payloads))


# ----------------------------------------------------------------------- reading


class SessionData(msgspec.Struct, kw_only=True, dict=True):
    """One recording's tables: name (a topic, or ``topic/list`` for exploded items) -> frame."""

    path: str
    session_id: str
    metadata: RecordingMetadata
    attachments: dict[str, bytes]
    tables: dict[str, pl.DataFrame]
    recovery: RecoveryReport | None = None
    """Set when the file was damaged: what could be read."""
    messages: int = 0
    """Messages of the loaded topics that were decoded."""
    streamed: Streamed | None = None
    """The per-tick topics folded by ``analysis.stream`` (``load_session(stream=True)``)."""

    def __getitem__(self, name: str) -> pl.DataFrame:
        """A table by name; one that was not loaded raises a ``KeyError`` saying which are,
        and how to load a topic left out (``/map`` is read only when asked for)."""
        table = self.tables.get(name)
        if table is not None:
            return table
        loaded = ", ".join(sorted(self.tables))
        if name in {t.value for t in Topic}:
            raise KeyError(
                f"topic {name!r} was not loaded: ask for it (open_recording(path,"
                f" topics=[..., {name!r}])); loaded: {loaded}"
            )
        raise KeyError(f"no table {name!r}; loaded: {loaded}")

    def __iter__(self) -> Iterator[str]:
        """The tables' names, sorted."""
        return iter(sorted(self.tables))

    def __contains__(self, name: object) -> bool:
        return name in self.tables

    @property
    def rows(self) -> int:
        return sum(t.height for t in self.tables.values())

    @property
    def tick_ms(self) -> int:
        """The tick length: from the recorded configuration, else 20 ms."""
        return 1000 // _tick_hz(self.metadata, self.path)


def _tick_hz(metadata: RecordingMetadata, path: str) -> int:
    """The recorded tick rate (50 when not recorded); RecordingError when it is not a
    rate of 1 to 1000 Hz (metadata records carry no CRC: a damaged byte shows here)."""
    text = (metadata.scenario and metadata.scenario.tick_hz) or "50"
    if not text.isdigit() or not 1 <= int(text) <= 1000:
        raise RecordingError(
            f"scenario metadata: tick_hz {text!r} is not 1 to 1000 Hz", source=path
        )
    return int(text)


def load_session(
    path: str | os.PathLike[str],
    *,
    topics: Iterable[Topic | str] | None = None,
    stream: bool = False,
) -> SessionData:
    """Load a recording's topics as polars tables (``DEFAULT_TOPICS`` unless ``topics``).

    With ``stream``, the per-tick topics are folded message by message instead
    (``SessionData.streamed``) and only :data:`LIGHT_TOPICS` become tables: memory then
    stays flat however long the session (what the metrics need).

    A damaged or truncated file is loaded up to where it can be read, with an
    :class:`AnalysisWarning` naming what was skipped. Raises
    ``recorder.errors.RecordingError`` when the file is not an oimi recording.
    """
    name = os.fspath(path)
    recording = open_recording(name)
    wanted = tuple(Topic(t) for t in topics) if topics is not None else DEFAULT_TOPICS
    if stream:
        wanted = tuple(t for t in wanted if t in LIGHT_TOPICS)
    payloads: dict[Topic, list[bytes]] = {t: [] for t in wanted}
    folder = StreamFolder(tick_ms=1000 // _tick_hz(recording.meta, name))
    tables = frozenset(t.value for t in wanted if t is not Topic.MAP)
    folded = frozenset(FOLDED) if stream else frozenset()
    streamed = 0
    with open(name, "rb") as file:
        scan = ChunkScan(file, tables | folded)
        for topic, _, _, data in scan.messages():
            if topic in folded:
                folder.add(topic, data)
            if topic in tables:  # the actuator commands are both
                payloads[Topic(topic)].append(data)
            else:
                streamed += 1
    if Topic.MAP in payloads:
        payloads[Topic.MAP] = _map_payloads(recording)
    recovery = recording.recovery or scan.report()
    if recovery is not None and not streamed and not any(payloads.values()):
        raise RecordingError(f"nothing recoverable: {recovery}", source=name)
    if recovery is not None:
        warnings.warn(
            f"{name}: {recovery}; analysed in part, the rest is skipped",
            AnalysisWarning,
            stacklevel=2,
        )
    tables: dict[str, pl.DataFrame] = {}
    for topic in wanted:
        try:
            tables.update(payloads_to_tables(topic, payloads[topic]))
        except pa.ArrowInvalid as error:  # a damaged payload in a chunk without a CRC
            raise RecordingError(
                f"{topic.value}: a message does not decode: {error}", source=name
            ) from None
    session_id = recording.meta.oimi.recording_id or os.path.splitext(os.path.basename(name))[0]
    return SessionData(
        path=name,
        session_id=session_id,
        metadata=recording.meta,
        attachments=recording.attachments,
        tables=tables,
        recovery=recovery,
        messages=sum(len(p) for p in payloads.values()) + streamed,
        streamed=folder.result() if stream else None,
    )
