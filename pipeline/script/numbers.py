"""Numbers as written in script files: strict decimal syntax and the ``o``/``0`` hint."""

from __future__ import annotations

import math
import re
from typing import Final

_FLOAT: Final = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?")
_INT: Final = re.compile(r"[+-]?\d+")


def parse_float(text: str) -> float | None:
    """The decimal number in ``text`` (surrounding spaces allowed), or None if it is not one."""
    text = text.strip()
    if not _FLOAT.fullmatch(text):
        return None
    value = float(text)
    return value if math.isfinite(value) else None


def parse_int(text: str) -> int | None:
    """The whole number in ``text`` (surrounding spaces allowed), or None if it is not one."""
    text = text.strip()
    return int(text) if _INT.fullmatch(text) else None


def not_a_number(text: str) -> str:
    """Why ``text`` is not a number, with a hint when the letter ``o`` stands for a zero.

    The thesis's printed examples show ``o`` where ``0`` is meant (a typesetting slip).
    """
    text = text.strip()
    if not text:
        return "a number is missing"
    message = f"'{text}' is not a number"
    fixed = text.replace("o", "0").replace("O", "0")
    if fixed != text and parse_float(fixed) is not None:
        message += f"; did you mean {fixed}?"
    return message


def format_number(value: float) -> str:
    """Shortest text that reads back as ``value`` (``10`` for 10.0, ``0.25``, ``1e-05``)."""
    value = float(value)
    if value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return repr(value)
