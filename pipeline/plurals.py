"""Counts said in words: ``1 script``, ``2 scripts``, ``3 activities``."""

from __future__ import annotations


def counted(count: int, noun: str) -> str:
    """``count`` and ``noun`` (singular; its last word is made plural unless ``count`` is 1:
    ``+s``, a consonant's ``y`` to ``ies``)."""
    if count == 1:
        return f"1 {noun}"
    if noun.endswith("y") and noun[-2:-1] not in ("a", "e", "i", "o", "u"):
        return f"{count} {noun[:-1]}ies"
    return f"{count} {noun}s"
