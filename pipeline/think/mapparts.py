"""The map's parts as bytes during one pass of the rule chain.

Two uses: a rule is skipped when every part its condition reads encodes as it did at
its last evaluation (``rules.Memo``), and a body's changes are found by comparing the
map's parts before and after it (only the parts that differ are decoded). Encodings
are msgpack, exact to the bit for numbers and twice as fast as JSON; a difference is
one when its values' JSON differs, so that diffs read as the recorded map does (``NaN``
is ``null``: two non-finite numbers make no change).
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Callable, Iterator
from typing import Any, Final

import msgspec
from oimi.pipeline.events import MapChange
from oimi.pipeline.jsontree import ABSENT, differences
from oimi.pipeline.messages import WorldMap
from oimi.pipeline.texts import clipped
from oimi.pipeline.think.condition_runtime import STORE_READS

MAX_CHANGE_TEXT: Final = 120
"""Longest value text kept in a decision's diff; longer values are cut with an ellipsis."""

FIELDS: Final = WorldMap.__struct_fields__
"""The map's top-level parts, in the order it encodes them."""
_STORES: Final = tuple(name for name in STORE_READS if name in FIELDS)
"""The map's parts a condition may write (its alias and variable stores)."""

_encode = msgspec.msgpack.Encoder().encode


class MapParts:
    """Encoded parts of one map, cached until :meth:`forget` (the caller forgets whatever
    may have changed the map: a rule body, a condition calling undeclared functions)."""

    def __init__(self, world_map: WorldMap) -> None:
        self.world_map = world_map
        self._encoded: dict[str, bytes] = {}
        self.baseline: dict[str, bytes | None] | None = None
        """Top-level parts as the last fired rule left them: the ``before`` of the next body
        (``None`` after a condition bound aliases or variables: not a body's doing); a part
        ``None`` is as the map has it (:meth:`defer`)."""

    def encoded(self, path: str) -> bytes:
        """The part at ``path`` (``"humans"``, ``"robotstatus.touch"``), encoded."""
        cached = self._encoded.get(path)
        if cached is None:
            cached = self._encoded[path] = _encode(_getter(path)(self.world_map))
        return cached

    def forget(self) -> None:
        """Drop every cached encoding (the map may have changed)."""
        self._encoded.clear()

    def rebound(self) -> None:
        """A condition bound or released aliases or variables (not a body's doing): their
        encodings are dropped, and the next body's ``before`` is taken as the map is then
        (kept, a body after it reported the binding as its own change)."""
        for name in _STORES:
            self._encoded.pop(name, None)
        self.baseline = None

    def before(self, names: tuple[str, ...]) -> dict[str, bytes]:
        """The top-level parts ``names`` before a body: as the last fired rule left them."""
        baseline = self.baseline
        if baseline is None:
            baseline = self.baseline = {}
        for name in names:
            if baseline.get(name) is None:
                baseline[name] = self.encoded(name)
        return {name: baseline[name] for name in names}  # type: ignore[misc]

    def defer(self, names: tuple[str, ...]) -> None:
        """Take the parts ``names`` that the baseline lacks as the map has them now, and
        encode them only when the map may change (:meth:`settle`): a body that changes
        nothing (it returns early) encodes none."""
        baseline = self.baseline
        if baseline is None:
            baseline = self.baseline = {}
        for name in names:
            baseline.setdefault(name, None)

    def settle(self) -> None:
        """Encode the parts :meth:`defer` left to the map: called before it may change."""
        baseline = self.baseline
        if baseline is not None and None in baseline.values():
            for name, data in baseline.items():
                if data is None:
                    baseline[name] = self.encoded(name)

    def after(self, names: tuple[str, ...], before: dict[str, bytes]) -> dict[str, bytes]:
        """The top-level parts ``names`` after a body (they become the baseline), each that
        changed checked against its type. A part the body left with a value of another
        type (a text where a number goes), or one that does not encode, would stop the
        stages after it (the safety supervisor reads the humans): every part the body may
        have changed is put back as in ``before`` and ``TypeError`` says what was wrong."""
        after: dict[str, bytes] = {}
        name = ""
        try:
            for name in names:
                data = after[name] = self.encoded(name)
                if data != before[name]:
                    _TYPED[name].decode(data)
        except (TypeError, ValueError, msgspec.ValidationError) as error:
            for part in names:
                _put_back(self.world_map, part, before[part])
            self.forget()
            self.baseline = None
            raise TypeError(f"{type_error(name, error)}; the body's changes are undone") from None
        self.baseline = {**(self.baseline or {}), **after}
        return after


Stores = tuple[tuple[tuple[str, str], ...], ...]
"""The items of the scope-U aliases and variables and of the tick scope, in order."""


def stores_of(world_map: WorldMap, tick_scope: dict[str, str]) -> Stores:
    """What the stores hold now (a condition reads them all, and may write them)."""
    return (
        tuple(world_map.aliases.items()),
        tuple(world_map.variables.items()),
        tuple(tick_scope.items()),
    )


_TYPED: Final = {
    field.name: msgspec.msgpack.Decoder(field.type) for field in msgspec.structs.fields(WorldMap)
}
"""Each top-level part's decoder: what checks a part's types after a body."""


def type_error(name: str, error: Exception) -> str:
    """What ``error`` found wrong in the map's part ``name``, said at its place
    (``humans[0].positionrho: Expected `float`, got `str```)."""
    text, _, at = str(error).partition(" - at `$")
    return f"{name}{at.rstrip('`')}: {text}"


def mistyped(world_map: WorldMap) -> str:
    """The first place in the map whose value is not of its type, as :func:`type_error`
    says it (``""`` when every part is of its type)."""
    for name in FIELDS:
        try:
            _TYPED[name].decode(_encode(getattr(world_map, name)))
        except (TypeError, ValueError, msgspec.ValidationError) as error:
            return type_error(name, error)
    return ""


def _put_back(world_map: WorldMap, name: str, data: bytes) -> None:
    """Make the part ``name`` hold ``data`` again, in place where it can (others may hold
    the list, dict or struct), else as a new value."""
    kept, value = getattr(world_map, name), _TYPED[name].decode(data)
    if type(kept) is list and type(value) is list:
        kept[:] = value
    elif type(kept) is dict and type(value) is dict:
        kept.clear()
        kept.update(value)
    elif type(kept) is type(value) and isinstance(value, msgspec.Struct):
        for field in value.__struct_fields__:
            setattr(kept, field, getattr(value, field))
    else:
        setattr(world_map, name, value)


@functools.cache
def _getter(path: str) -> Callable[[WorldMap], Any]:
    return operator.attrgetter(path)


def map_changes(before: dict[str, bytes], after: dict[str, bytes]) -> tuple[MapChange, ...]:
    """The changes between the parts :meth:`MapParts.before` and :meth:`MapParts.after`
    gave, as :func:`diff` gives them for the whole maps (parts in the map's order; only
    the parts that differ are decoded)."""
    return tuple(
        change
        for name in FIELDS
        if name in before and before[name] != after[name]
        for change in _part_changes(before[name], after[name], name)
    )


def _part_changes(old: bytes, new: bytes, name: str) -> Iterator[MapChange]:
    """:func:`diff` of one part's encodings. A list of as many items before as after is
    compared item by item, and only the items whose encodings differ are decoded (equal
    bytes make no change), as :func:`diff` walks a list of unchanged length."""
    try:
        olds, news = _items(old), _items(new)
    except msgspec.ValidationError:  # not a list: decoded whole
        olds = news = []
    if not olds or len(olds) != len(news):
        yield from diff(_decode(old), _decode(new), name)
        return
    for index, (a, b) in enumerate(zip(olds, news, strict=True)):
        if a != b:
            yield from diff(_decode(a), _decode(b), f"{name}[{index}]")


_decode: Final = msgspec.msgpack.Decoder().decode
_items: Final = msgspec.msgpack.Decoder(list[msgspec.Raw]).decode


def diff(old: Any, new: Any, path: str = "") -> Iterator[MapChange]:
    """The leaves whose JSON differs between two builtin trees, as compact ``MapChange``s
    (a list whose length changed is one change; a missing key reads as ``null``)."""
    for where, a, b in differences(old, new, path, whole_lists=True):
        a, b = _json(None if a is ABSENT else a), _json(None if b is ABSENT else b)
        if a != b:
            yield MapChange(path=where, old=_cut(a), new=_cut(b))


_json: Final = msgspec.json.Encoder().encode


def _cut(text: bytes) -> str:
    return clipped(text.decode(), MAX_CHANGE_TEXT)
