"""Texts shown to people, kept short."""

from __future__ import annotations

import difflib
from collections.abc import Callable, Iterable


def clipped(text: str, chars: int) -> str:
    """``text`` when it has at most ``chars`` characters, else its start and ``…`` in that
    many."""
    return text if len(text) <= chars else text[: chars - 1] + "…"


def did_you_mean(word: str, options: Iterable[str], *, shown: Callable[[str], str] = repr) -> str:
    """``; did you mean 'x'?`` naming the option nearest ``word`` (``shown`` as it is
    written), or ``""`` when none is near (difflib's closeness, 0.6)."""
    close = difflib.get_close_matches(word, list(options), n=1)
    return meant(close[0], shown=shown) if close else ""


def meant(option: str, *, shown: Callable[[str], str] = repr) -> str:
    """``; did you mean 'x'?`` for an ``option`` known to be the one meant."""
    return f"; did you mean {shown(option)}?"
