"""``/map`` as keyframes and deltas: what the loop publishes, and the way back to full maps.

:class:`MapDeltas` keeps a copy of every part of the map it last published (each section
of ``WorldMap`` and each row of each listed class, by id) and, after a tick, compares the
live map with them by value (struct equality: one C call per unchanged table, no JSON
encoded or decoded to find what changed). Only the parts that differ are encoded (into the
:class:`~pipeline.events.MapDelta`, as ``msgspec.Raw``: the sink writes them as they are);
a row that was there before is written as its change (its id and the fields that differ;
a register that took readings as the readings added and how many it dropped, not its
whole history; format 9 leaves out a field that repeats the newest reading its register
added, such as a person's ``positionrho`` and the pose just added), and that change is what
its kept copy takes (the readings it kept are not copied again). :func:`apply_delta` is the
one function that rebuilds full maps from a keyframe and the deltas after it.

A recorded part is the live part's JSON at its change, so a rebuilt map equals the loop's
(``==``). A change between values that compare equal is not one (``0.0`` and ``-0.0``; an
entity's ``attributes`` reordered; the top-level dicts' key order is compared); and a
value decodes into its field's type (an int a Python caller put in a float field comes
back a float).
"""

from __future__ import annotations

import copy
import enum
from typing import Any, Final

import msgspec
from oimi.pipeline.events import ROW_PATCHES, SECTION_PATCHES, Appended, MapDelta
from oimi.pipeline.messages import MAP_LISTS, WorldMap
from oimi.pipeline.sense.updates import UPDATE_TABLE, EntityClass

TABLES: Final = tuple(m.field for m in MAP_LISTS)
"""The map's listed classes' fields (rows with ids: a delta lists the changed rows)."""
SECTIONS: Final = tuple(f for f in WorldMap.__struct_fields__ if f not in TABLES)
"""The map's other fields (a delta holds each whole, when it changed)."""
_CLASS: Final = {m.field: m.name for m in MAP_LISTS}
_FIELD: Final = {m.name: m.field for m in MAP_LISTS}
_DECODERS: Final[dict[str, msgspec.json.Decoder[Any]]] = {
    f.name: msgspec.json.Decoder(f.type)
    for f in msgspec.structs.fields(WorldMap)
    if f.name in SECTIONS
} | {m.field: msgspec.json.Decoder(m.struct) for m in MAP_LISTS}
"""Each section's and each table's row's decoder (whole, as in a keyframe)."""
_PATCH_DECODERS: Final = {
    part: msgspec.json.Decoder(patch) for part, patch in (ROW_PATCHES | SECTION_PATCHES).items()
}
"""Each table's row change's and each Struct section's change's decoder."""
_REPEATS: Final[dict[type, tuple[tuple[str, tuple[str, ...]], ...]]] = {
    m.struct: tuple(
        (spec.name, spec.mirrors)
        for spec in UPDATE_TABLE[EntityClass(m.name)].values()
        if spec.mirrors
    )
    for m in MAP_LISTS
}
"""Each row type's registers whose newest reading repeats fields of the row, with those
fields (the Map Producer copies an added pose onto an entity's ``positionrho``,
``positiontheta`` and ``positionchangetime``: the update table's ``mirrors``)."""
_encode: Final = msgspec.json.Encoder().encode
_astuple: Final = msgspec.structs.astuple
_Raw: Final = msgspec.Raw
_UNSET: Final[Any] = object()


def _copy(value: Any) -> Any:
    """A copy to compare with later, sharing what cannot change in place (numbers, texts,
    frozen structs such as a register's readings): lists, dicts and mutable structs are
    new, so a later change to the map never reaches the copy. Comparing it with the live
    map is then mostly identity checks (``list.__eq__`` compares its items by identity
    first), and copying a person's row copies three containers, not 32 readings."""
    kind = type(value)
    if kind in _SHARED:
        return value
    if kind is list:
        return value.copy() if _SHARED.issuperset(map(type, value)) else [_copy(v) for v in value]
    if kind is dict:
        if _SHARED.issuperset(map(type, value.values())):
            return value.copy()
        return {k: _copy(v) for k, v in value.items()}
    if isinstance(value, msgspec.Struct):
        if kind.__struct_config__.frozen:
            _SHARED.add(kind)
            return value
        twin = copy.copy(value)
        for name, field in zip(kind.__struct_fields__, msgspec.structs.astuple(value), strict=True):
            if type(field) not in _SHARED:
                setattr(twin, name, _copy(field))
        return twin
    if kind is tuple and _SHARED.issuperset(map(type, value)):
        return value
    if isinstance(value, enum.Enum):  # a member is its own copy (deepcopy returns it)
        _SHARED.add(kind)
        return value
    return copy.deepcopy(value)


_SHARED: Final[set[type]] = {str, int, float, bool, type(None), bytes}
"""Types whose values never change in place (frozen structs and enums join when first
met)."""


class MapDeltas:
    """The loop's ``/map`` publisher: the message after a tick, when the map changed.

    ``keyframe_ms``: a keyframe is written at the first publish and then at the first
    change at least this long after the previous keyframe (also when a table's rows
    cannot be said as a delta: two rows with one id, or rows that changed order).
    """

    def __init__(self, *, keyframe_ms: int) -> None:
        self.keyframe_ms = keyframe_ms
        self._keyframe_ms: int | None = None
        self._sections: dict[str, Any] = dict.fromkeys(SECTIONS, _UNSET)
        """A copy of each section as last published."""
        self._rows: dict[str, list[Any]] = {t: [] for t in TABLES}
        """A copy of each table's rows as last published, in the map's order."""
        self._ids: dict[str, dict[str, Any]] = {t: {} for t in TABLES}

    def after(self, world_map: WorldMap, *, tick: int, time_ms: int) -> MapDelta | None:
        """The ``/map`` message for the map after ``tick``; None when it did not change."""
        sections: dict[str, Any] = {}
        """The sections that changed, as a delta writes them (a Struct section as its change)."""
        kept_sections = self._sections
        for name in SECTIONS:
            live = getattr(world_map, name)
            kept = kept_sections[name]  # a dict's key order shows in its JSON: compared too
            if kept == live and (type(live) is not dict or list(kept) == list(live)):
                continue
            if name in SECTION_PATCHES and kept is not _UNSET:
                sections[name] = _change(kept, live)  # (no section repeats)
            else:
                kept_sections[name] = _copy(live)
                sections[name] = live
        keyframe = self._keyframe_ms is None or time_ms - self._keyframe_ms >= self.keyframe_ms
        tables: dict[str, tuple[msgspec.Raw, ...]] = {}
        removed: list[str] = []
        for table in TABLES:
            live_rows: list[Any] = getattr(world_map, table)
            if live_rows == self._rows[table]:
                continue
            rows, gone, ordered = self._table(table, live_rows)
            tables[table] = rows
            if gone:  # (most changes remove nothing)
                removed += (f"{_CLASS[table]}/{i}" for i in gone)
            keyframe = keyframe or not ordered
        if not sections and not tables:
            return None
        if not keyframe:
            return MapDelta(
                tick=tick,
                time_ms=time_ms,
                removed=tuple(removed),
                **{name: msgspec.Raw(_encode(change)) for name, change in sections.items()},
                **tables,
            )
        self._keyframe_ms = time_ms
        return MapDelta(
            tick=tick,
            time_ms=time_ms,
            keyframe=True,
            **{name: msgspec.Raw(_encode(getattr(world_map, name))) for name in SECTIONS},
            **{t: tuple(msgspec.Raw(_encode(r)) for r in getattr(world_map, t)) for t in TABLES},
        )

    def _table(
        self, table: str, live: list[Any]
    ) -> tuple[tuple[msgspec.Raw, ...], list[str], bool]:
        """Update a table's kept rows to ``live``: the rows that changed or appeared (their
        JSON), the ids gone, and whether a delta can say it (unique ids, kept rows in their
        old order, new ones at the end)."""
        kept = self._ids[table]
        rows = []
        fresh: dict[str, Any] = {}
        for row in live:
            old = kept.get(row.id)
            if old is None:
                rows.append(_Raw(_encode(row)))
                old = _copy(row)
            elif old != row:
                rows.append(_Raw(_encode(_change(old, row))))
            fresh[row.id] = old
        self._ids[table] = fresh
        if len(fresh) == len(kept) == len(live) and list(fresh) == list(kept):
            # the same rows in the same order (the usual change: some of them changed)
            self._rows[table] = list(fresh.values())
            return tuple(rows), [], True
        ids = [row.id for row in live]
        gone = [i for i in kept if i not in fresh]
        expected = [i for i in kept if i in fresh] + [i for i in fresh if i not in kept]
        unique = len(fresh) == len(ids)
        self._rows[table] = [fresh[i] for i in ids] if unique else [_copy(r) for r in live]
        return tuple(rows), gone, unique and expected == ids


def _change(kept: Any, new: Any) -> dict[str, Any]:
    """A row's (same id) or a section's change from its kept copy to ``new``, as a delta
    writes it, with ``kept`` brought up to date: the fields that differ (copied into
    ``kept``); a list that kept a run of its old items at its start as what it dropped and
    added (``kept`` keeps the readings it kept, they are copies already, and copies those
    added); and (format 9) a field equal to the newest reading its register added left out
    (read back from the reading), one that differs from it written even when unchanged."""
    names = new.__struct_fields__
    change = {"id": new.id} if "id" in names else {}
    befores = _astuple(kept)
    for i, after in enumerate(_astuple(new)):
        before = befores[i]
        if before == after:
            continue
        name = names[i]
        if type(after) is list and type(before) is list:
            if _took_one(before, after):  # (the usual change, ``before`` now as ``after``)
                change[name] = Appended(dropped=1, added=after[-1:])
                continue
            dropped = _dropped(before, after)
            if dropped is not None:
                added = after[len(before) - dropped :]
                change[name] = Appended(dropped=dropped, added=added)
                for reading in added:  # (joined to a new list: its items alone need copies)
                    if type(reading) not in _SHARED:
                        added = _copy(added)
                        break
                setattr(kept, name, before[dropped:] + added)
                continue
        change[name] = after
        setattr(kept, name, after if type(after) in _SHARED else _copy(after))
    for register, mirrors in _REPEATS.get(type(new), ()):
        appended = change.get(register)
        if type(appended) is not Appended:
            continue
        added = appended.added
        if not added:
            continue
        newest = added[-1]
        for name in mirrors:
            value = getattr(new, name)
            if value == getattr(newest, name):
                change.pop(name, None)
            else:
                change[name] = value
    return change


def _took_one(kept: list[Any], live: list[Any]) -> bool:
    """Whether the register ``live`` is its kept copy ``kept`` that dropped its oldest
    reading and took one (a full register took a reading: the usual change); then ``kept``
    is brought up to date in place (it is this publisher's own copy; the reading copied
    unless of a type that never changes in place), found without slicing either list. Else
    ``kept`` is left as it was."""
    if len(kept) < 2 or len(live) != len(kept):
        return False
    oldest = kept.pop(0)
    taken = live[-1]
    kept.append(taken)
    if kept == live:  # (the reading taken is itself: only the kept ones are compared)
        if type(taken) not in _SHARED:
            kept[-1] = _copy(taken)
        return True
    kept.pop()
    kept.insert(0, oldest)
    return False


def _dropped(before: list[Any], after: list[Any]) -> int | None:
    """How many items ``before`` dropped from its start if ``after`` begins with the rest
    of them (then it added what follows); None if it did not (it is written whole). The
    lists differ (the least count is found: a register of one that took a reading is
    written whole, as no item of it is kept)."""
    size = len(before)
    if not after:
        return None
    first = after[0]
    dropped = -1
    while True:  # (each item equal to ``first``, in order: a C-level search)
        try:
            dropped = before.index(first, dropped + 1)
        except ValueError:
            return None
        if after[: size - dropped] == before[dropped:]:
            return dropped


def _applied(row: Any, patch: Any, repeats: bool) -> Any:
    """``row`` (left unchanged) with a :data:`~pipeline.events.ROW_PATCHES` change, or a
    section with a :data:`~pipeline.events.SECTION_PATCHES` one; ``repeats``: a field the
    change leaves out is the newest reading's its register added (format 9)."""
    fields = {}
    if repeats:
        for register, names in _REPEATS.get(type(row), ()):
            appended = getattr(patch, register)
            if type(appended) is Appended and appended.added:
                newest = appended.added[-1]
                fields.update(
                    (n, getattr(newest, n)) for n in names if getattr(patch, n) is msgspec.UNSET
                )
    for name in row.__struct_fields__:
        value = getattr(patch, name)
        if value is msgspec.UNSET:
            continue
        if type(value) is Appended:
            register = getattr(row, name)
            if not 0 <= value.dropped <= len(register):
                owner = (
                    f"{type(row).__name__}/{row.id}" if hasattr(row, "id") else type(row).__name__
                )
                raise ValueError(
                    f"drops {value.dropped} of the {len(register)} items of {owner}'s {name}"
                )
            value = register[value.dropped :] + value.added
        fields[name] = value
    return msgspec.structs.replace(row, **fields)


def apply_delta(world_map: WorldMap | None, delta: MapDelta, *, repeats: bool = True) -> WorldMap:
    """The map after ``delta``: a keyframe's map (a section it lacks has its default), or
    ``world_map`` (the map of the previous ``/map`` message, left unchanged) with the
    delta's sections and rows in place, its new rows appended and its removed rows dropped.
    The result shares its unchanged parts with ``world_map``: treat it as read-only.
    ``repeats``: a changed row's field that repeats its register's newest reading is left
    out of the delta (format 9; False for older recordings, which wrote it).
    ValueError for a delta with no map to apply to, or one that removes a row the map
    does not have (``msgspec.DecodeError`` for a part that does not decode)."""
    if delta.keyframe:
        return WorldMap(
            **{n: _DECODERS[n].decode(getattr(delta, n)) for n in SECTIONS if getattr(delta, n)},
            **{t: [_DECODERS[t].decode(r) for r in getattr(delta, t)] for t in TABLES},
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
        data, kept = getattr(delta, name), getattr(world_map, name)
        if not data:
            fields[name] = kept
        elif name in SECTION_PATCHES:
            fields[name] = _patched(kept, _PATCH_DECODERS[name].decode(data), delta.tick, repeats)
        else:
            fields[name] = _DECODERS[name].decode(data)
    for table in TABLES:
        rows: list[Any] = getattr(world_map, table)
        changed = _changed_rows(table, rows, getattr(delta, table), delta.tick, repeats)
        dropped = gone.get(table, set())
        if changed or dropped:
            rows = [changed.pop(r.id, r) for r in rows if r.id not in dropped]
            rows += changed.values()
        fields[table] = list(rows)
    return WorldMap(**fields)


def _changed_rows(
    table: str, rows: list[Any], raws: tuple[msgspec.Raw, ...], tick: int, repeats: bool
) -> dict[str, Any]:
    """A delta's rows of ``table`` rebuilt, by id: a change applied to the row ``rows`` has
    with its id, else a whole new row."""
    if not raws:
        return {}
    before = {row.id: row for row in rows}
    changed = {}
    for raw in raws:
        patch = _PATCH_DECODERS[table].decode(raw)
        row = before.get(patch.id)
        if row is None:
            changed[patch.id] = _DECODERS[table].decode(raw)
            continue
        changed[patch.id] = _patched(row, patch, tick, repeats)
    return changed


def _patched(part: Any, patch: Any, tick: int, repeats: bool) -> Any:
    """:func:`_applied`, its error naming the delta's tick."""
    try:
        return _applied(part, patch, repeats)
    except ValueError as error:
        raise ValueError(f"the delta of tick {tick} {error}") from None
