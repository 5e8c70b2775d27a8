"""``/map`` as keyframes and deltas: what the loop publishes, and the way back to full maps.

:class:`MapDeltas` keeps a copy of every part of the map it last published (each section
of ``WorldMap`` and each row of each listed class, by id) and, after a tick, compares the
live map with them by value (struct equality, one C call per unchanged table): only the
parts that differ are copied and go into the :class:`~pipeline.events.MapDelta`. No JSON
is encoded or decoded to find what changed. :func:`apply_delta` is the one function that
rebuilds the full map from a keyframe and the deltas after it.

Compared by value, the rebuilt map equals the loop's (``==``); JSON spellings that compare
equal are not told apart (``0.0`` and ``-0.0``; an entity's ``attributes`` in another
key order; the top-level dicts' key order is kept), and an int in a float field (a value
built in Python) is copied, so recorded, as a float.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from typing import Any, Final

import msgspec
from oimi.pipeline.events import MapDelta
from oimi.pipeline.messages import MAP_LISTS, WorldMap

TABLES: Final = tuple(m.field for m in MAP_LISTS)
"""The map's listed classes' fields (rows with ids: a delta lists the changed rows)."""
SECTIONS: Final = tuple(f for f in WorldMap.__struct_fields__ if f not in TABLES)
"""The map's other fields (a delta holds each whole, when it changed)."""
_CLASS: Final = {m.field: m.name for m in MAP_LISTS}
_FIELD: Final = {m.name: m.field for m in MAP_LISTS}
_UNSET: Final[Any] = object()


def _copy(value: Any) -> Any:
    """A deep copy: Structs through msgpack (fast, every float bit kept), or ``deepcopy``
    for what a typed decode would refuse or change (an int beyond 64 bits; a value of
    another type than its field's, which an extension's rule may write): the copy, and so
    the recorded delta, holds exactly what the map held."""
    if isinstance(value, msgspec.Struct):
        try:
            return msgspec.msgpack.decode(msgspec.msgpack.encode(value), type=type(value))
        except (OverflowError, msgspec.ValidationError):
            return copy.deepcopy(value)
    if isinstance(value, dict):
        return dict(value)
    return value


class MapDeltas:
    """The loop's ``/map`` publisher: the message after a tick, when the map changed.

    ``keyframe_ms``: a keyframe is written at the first publish and then at the first
    change at least this long after the previous keyframe (also when the rows of a
    table cannot be told apart by id or changed order in a way a delta cannot say).
    """

    def __init__(self, *, keyframe_ms: int) -> None:
        self.keyframe_ms = keyframe_ms
        self._keyframe_ms: int | None = None
        self._sections: dict[str, Any] = dict.fromkeys(SECTIONS, _UNSET)
        self._rows: dict[str, list[Any]] = {t: [] for t in TABLES}
        """Each table's kept rows, in the map's order."""
        self._ids: dict[str, dict[str, Any]] = {t: {} for t in TABLES}

    def after(self, world_map: WorldMap, *, tick: int, time_ms: int) -> MapDelta | None:
        """The ``/map`` message for the map after ``tick``; None when it did not change."""
        changed: dict[str, Any] = {}
        sections = self._sections
        for name in SECTIONS:
            live = getattr(world_map, name)
            kept = sections[name]  # a dict's key order shows in its JSON: compared too
            if kept == live and (type(live) is not dict or list(kept) == list(live)):
                continue
            changed[name] = sections[name] = _copy(live)
        removed: list[str] = []
        keyframe = self._keyframe_ms is None or time_ms - self._keyframe_ms >= self.keyframe_ms
        for table in TABLES:
            live_rows: list[Any] = getattr(world_map, table)
            if live_rows == self._rows[table]:
                continue
            rows, gone, ordered = self._table(table, live_rows)
            changed[table] = rows
            removed += (f"{_CLASS[table]}/{i}" for i in gone)
            keyframe = keyframe or not ordered
        if not changed:
            return None
        if keyframe:
            self._keyframe_ms = time_ms
            return MapDelta(
                tick=tick,
                time_ms=time_ms,
                keyframe=True,
                **self._sections,
                **{t: tuple(self._rows[t]) for t in TABLES},
            )
        return MapDelta(tick=tick, time_ms=time_ms, removed=tuple(removed), **changed)

    def _table(self, table: str, live: Sequence[Any]) -> tuple[tuple[Any, ...], list[str], bool]:
        """Update a table's kept rows to ``live``: the rows that changed or appeared, the ids
        gone, and whether a delta can say it (unique ids, kept rows in their old order,
        new ones at the end)."""
        kept = self._ids[table]
        ids = [row.id for row in live]
        rows = []
        fresh: dict[str, Any] = {}
        for row in live:
            old = kept.get(row.id)
            if old is None or old != row:
                old = _copy(row)
                rows.append(old)
            fresh[row.id] = old
        gone = [i for i in kept if i not in fresh]
        expected = [i for i in kept if i in fresh] + [i for i in ids if i not in kept]
        self._ids[table] = fresh
        self._rows[table] = (
            [fresh[i] for i in ids] if len(fresh) == len(ids) else [_copy(row) for row in live]
        )
        return tuple(rows), gone, expected == ids


def apply_delta(world_map: WorldMap | None, delta: MapDelta) -> WorldMap:
    """The map after ``delta``: a keyframe's map (a section it lacks has its default), or
    ``world_map`` (the map of the previous ``/map`` message, left unchanged) with the
    delta's sections and rows in place, its new rows appended and its removed rows dropped.
    The result shares its unchanged parts with ``world_map`` and ``delta``: treat it as
    read-only. ValueError for a delta with no map to apply to, or one that removes a row
    the map does not have."""
    if delta.keyframe:
        sections = {name: getattr(delta, name) for name in SECTIONS}
        return WorldMap(
            **{name: value for name, value in sections.items() if value is not None},
            **{table: list(getattr(delta, table)) for table in TABLES},
        )
    if world_map is None:
        raise ValueError(f"the delta of tick {delta.tick} has no keyframe before it")
    gone: dict[str, set[str]] = {}
    for objectid in delta.removed:
        name, _, ident = objectid.partition("/")
        if name not in _FIELD or all(r.id != ident for r in getattr(world_map, _FIELD[name])):
            raise ValueError(f"the delta of tick {delta.tick} removes {objectid!r}, not in the map")
        gone.setdefault(_FIELD[name], set()).add(ident)
    fields: dict[str, Any] = {}
    for name in SECTIONS:
        value = getattr(delta, name)
        fields[name] = getattr(world_map, name) if value is None else value
    for table in TABLES:
        rows: list[Any] = getattr(world_map, table)
        changed = {row.id: row for row in getattr(delta, table)}
        dropped = gone.get(table, set())
        if changed or dropped:
            rows = [changed.pop(r.id, r) for r in rows if r.id not in dropped]
            rows += changed.values()
        fields[table] = list(rows)
    return WorldMap(**fields)
