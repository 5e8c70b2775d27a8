"""The keys a scenario file's table takes at a place, for a mistyped key's suggestion."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from msgspec import inspect
from oimi.pipeline.texts import did_you_mean
from oimi.scenarios.schema import Scenario


def fields_at(path: Sequence[str | int], document: Any) -> tuple[str, ...]:
    """The keys the table at ``path`` of a scenario ``document`` (its TOML, as decoded)
    takes, by the schema; none where the path does not lead to a table of the schema (a
    tagged table, such as a behaviour segment, by its ``kind``)."""
    info: Any = _chosen(inspect.type_info(Scenario), document)
    node = document
    for key in path:
        if isinstance(info, inspect.StructType) and isinstance(key, str):
            field = next((f for f in info.fields if f.encode_name == key), None)
            info = field.type if field is not None else None
        elif isinstance(info, inspect.ListType | inspect.VarTupleType) and isinstance(key, int):
            info = info.item_type
        elif isinstance(info, inspect.DictType):
            info = info.value_type
        else:
            return ()
        node = _child(node, key)
        info = _chosen(info, node)
    return tuple(f.encode_name for f in info.fields) if isinstance(info, inspect.StructType) else ()


def suggestion(key: str, path: Sequence[str | int], document: Any) -> str:
    """``"; did you mean NAME?"`` for an unknown ``key`` of the table at ``path`` that is
    close to one it takes (else "")."""
    return did_you_mean(key, fields_at(path, document), shown=str)


def _child(node: Any, key: str | int) -> Any:
    try:
        return node[key]
    except (KeyError, IndexError, TypeError):
        return None


def _chosen(info: Any, node: Any) -> Any:
    """The type a value takes of a union (its tag picks the table's; else the one that is
    not None)."""
    if not isinstance(info, inspect.UnionType):
        return info
    tables = [t for t in info.types if isinstance(t, inspect.StructType)]
    for table in tables:
        tag = table.tag_field
        if tag is not None and isinstance(node, dict) and node.get(tag) == table.tag:
            return table
    others = [t for t in info.types if not isinstance(t, inspect.NoneType)]
    if len(others) == 1:
        return others[0]
    untagged = [t for t in tables if t.tag_field is None]
    return untagged[0] if len(untagged) == 1 else None
