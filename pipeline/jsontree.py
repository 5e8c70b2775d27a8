"""Differences between two JSON trees (decoded builtins: dicts, lists, leaves).

The one walker behind a rule decision's map changes (``pipeline.think.mapparts.diff``)
and replay's first differing field (``replay.compare.first_difference``).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any, Final


class _Absent:
    """The side of a difference where a key or list item does not exist."""

    def __repr__(self) -> str:
        return "<absent>"


ABSENT: Final = _Absent()


def differences(
    old: Any, new: Any, path: str = "", *, whole_lists: bool = False, exact: bool = False
) -> Iterator[tuple[str, Any, Any]]:
    """Each differing leaf as ``(path, old, new)``, depth first, in key order (``old``'s
    keys, then those only ``new`` has). Paths extend ``path`` with ``.key`` (``key`` alone
    at the root when ``path`` is empty) and ``[index]``; a key or item on one side only
    gives :data:`ABSENT` on the other. Lists of different lengths differ item by item
    (then each extra index), or as one whole-list difference with ``whole_lists``.
    Subtrees that compare equal are skipped in one comparison, unless ``exact``: then
    leaves also differ by type (``1`` and ``1.0``, ``1`` and ``true``)."""
    if old == new and (not exact or _same_types(old, new)):
        return
    if isinstance(old, dict) and isinstance(new, dict):
        for key in [*old, *(k for k in new if k not in old)]:
            yield from differences(
                old.get(key, ABSENT),
                new.get(key, ABSENT),
                f"{path}.{key}" if path else str(key),
                whole_lists=whole_lists,
                exact=exact,
            )
    elif (
        isinstance(old, list)
        and isinstance(new, list)
        and (len(old) == len(new) or not whole_lists)
    ):
        for index in range(max(len(old), len(new))):
            yield from differences(
                old[index] if index < len(old) else ABSENT,
                new[index] if index < len(new) else ABSENT,
                f"{path}[{index}]",
                whole_lists=whole_lists,
                exact=exact,
            )
    else:
        yield path, old, new


def _same_types(old: Any, new: Any) -> bool:
    """Two equal trees are also equal leaf type for leaf type."""
    if type(old) is not type(new):
        return False
    if isinstance(old, dict):
        return all(_same_types(v, new[k]) for k, v in old.items())
    if isinstance(old, list):
        return all(_same_types(a, b) for a, b in zip(old, new, strict=True))
    return True
