"""Texts shown to people, kept short."""

from __future__ import annotations


def clipped(text: str, chars: int) -> str:
    """``text`` when it has at most ``chars`` characters, else its start and ``…`` in that
    many."""
    return text if len(text) <= chars else text[: chars - 1] + "…"
