"""Where each part of a Script was written: JSON paths mapped to line and column."""

from __future__ import annotations

import bisect
import re
from typing import Final

from oimi.pipeline.messages import Script
from oimi.pipeline.script.errors import ScriptError

_LAST_STEP: Final = re.compile(r"^(.*?)(\.[^./\[\]]+|\[\d+\]|/[^/.\[\]]+)$")
_STEP_KEY: Final = re.compile(r"(?:act|blk)\d+")

Position = tuple[int, int]
"""Line and column, both counted from 1."""


def parent_path(path: str) -> str:
    """``goal0/act0/blk2.move[1].v_x`` -> ``goal0/act0/blk2.move[1]`` ... -> ``""``."""
    match = _LAST_STEP.match(path)
    return match.group(1) if match else ""


def child_path(parent: str, key: str) -> str:
    """The path of ``key`` inside ``parent``: ``/`` before ``actN``/``blkN``, ``.`` otherwise."""
    if not parent:
        return key
    joiner = "/" if _STEP_KEY.fullmatch(key) else "."
    return f"{parent}{joiner}{key}"


CONTEXT_CHARS: Final = 120
"""Longest piece of a source line shown under an error."""


class LineIndex:
    """Turns character offsets of a text into (line, column), both from 1."""

    def __init__(self, text: str):
        self.text = text
        self._starts = [0] + [i + 1 for i, char in enumerate(text) if char == "\n"]

    def position(self, offset: int) -> Position:
        line = bisect.bisect_right(self._starts, offset)
        return line, offset - self._starts[line - 1] + 1

    def offset(self, line: int, column: int) -> int:
        return self._starts[line - 1] + column - 1

    def context(self, line: int, column: int) -> str:
        """The source line and a caret under ``column``; a long line is cut to a window of
        ``CONTEXT_CHARS`` around the column, each cut shown by ``…``."""
        if not 1 <= line <= len(self._starts):
            return ""
        start = self._starts[line - 1]
        end = self.text.find("\n", start)
        end = len(self.text) if end < 0 else end
        first = max(start, min(start + column - 1 - CONTEXT_CHARS // 2, end - CONTEXT_CHARS))
        last = min(end, first + CONTEXT_CHARS)
        head, tail = ("…" if first > start else ""), ("…" if last < end else "")
        text = head + self.text[first:last].rstrip() + tail
        before = self.text[first : start + column - 1]
        caret = " " * len(head) + "".join("\t" if char == "\t" else " " for char in before)
        return f"{text}\n{caret}^"


class SourceMap:
    """Positions of a script's parts, by path; a part not found falls back to its parent."""

    def __init__(self, source: str, lines: LineIndex, *, json_strings: bool = False):
        self.source = source
        self.lines = lines
        self.json_strings = json_strings
        """Values are JSON string literals (escapes like ``\\"`` take more than one char)."""
        self._keys: dict[str, Position] = {}
        self._values: dict[str, Position] = {}

    def add(self, path: str, key: Position, value: Position | None = None) -> None:
        """Record where ``path`` was written (its key) and where its value starts."""
        self._keys.setdefault(path, key)
        self._values.setdefault(path, value or key)

    def locate(self, path: str) -> Position:
        """Where ``path`` (or its nearest recorded parent) was written; (1, 1) if nowhere."""
        while True:
            if path in self._keys:
                return self._keys[path]
            if not path:
                return (1, 1)
            path = parent_path(path)

    def value_position(self, path: str) -> Position | None:
        """Where the value of ``path`` starts (e.g. the first character of a condition)."""
        return self._values.get(path)

    def text_position(self, path: str, index: int) -> Position | None:
        """Where character ``index`` (from 0) of the text value of ``path`` was written.

        Follows line breaks, and JSON escapes when the file is JSON (``\\"`` is one char).
        """
        start = self.value_position(path)
        if start is None:
            return None
        raw = self.lines.text
        offset = self.lines.offset(*start)
        for _ in range(max(index, 0)):
            if offset >= len(raw):
                break
            if self.json_strings and raw[offset] == "\\":
                offset += 6 if raw[offset + 1 : offset + 2] == "u" else 2
            else:
                offset += 1
        return self.lines.position(min(offset, len(raw)))

    def place(self, error: ScriptError) -> ScriptError:
        """``error`` with this file's name and the line and column of its path."""
        line, column = self.locate(error.path)
        return ScriptError(
            error.message,
            source=self.source,
            line=line,
            column=column,
            path=error.path,
            context=self.lines.context(line, column),
        )


class ParsedScript:
    """A Script with the map of where its parts were written."""

    def __init__(self, script: Script, sourcemap: SourceMap):
        self.script = script
        self.sourcemap = sourcemap


def decode_text(data: str | bytes, *, source: str) -> str:
    """The text of a script file; a binary or non-UTF-8 file is a ScriptError."""
    if isinstance(data, bytes):
        if b"\x00" in data:
            raise _binary_error(source, data, data.index(b"\x00"), "it contains NUL bytes")
        try:
            text = data.decode("utf-8-sig")
        except UnicodeDecodeError as error:
            reason = f"invalid UTF-8 byte 0x{data[error.start]:02x}"
            raise _binary_error(source, data, error.start, reason) from None
    else:
        text = data.removeprefix("\ufeff")
        if "\x00" in text:
            raise _binary_error(source, text, text.index("\x00"), "it contains NUL characters")
    return text


def _binary_error(source: str, data: str | bytes, offset: int, reason: str) -> ScriptError:
    newline = b"\n" if isinstance(data, bytes) else "\n"
    line = data.count(newline, 0, offset) + 1  # type: ignore[arg-type]
    column = offset - (data.rfind(newline, 0, offset) + 1) + 1  # type: ignore[arg-type]
    return ScriptError(
        f"not a text script ({reason}): is this a binary file?",
        source=source,
        line=line,
        column=column,
    )
