"""Errors that point at a place in a file or text: ``FILE:LINE:COL: message``."""

from __future__ import annotations

import os
import re
import traceback
from typing import Final

WORD_CHARS: Final = 100
"""Longest word (a run without spaces) a message quotes in full; a longer one, such as
an unexpected token on a huge line, keeps its start and end around ``…``."""
_LONG_WORD: Final = re.compile(rf"\S{{{WORD_CHARS + 1},}}")


def _cut(match: re.Match[str]) -> str:
    word = match.group(0)
    return word[: WORD_CHARS * 3 // 4] + "…" + word[-(WORD_CHARS // 4) :]


class LocatedError(Exception):
    """A user-input error with the place it was found (line and column count from 1)."""

    also: tuple[LocatedError, ...] = ()
    """Other problems of the same input found with this one, each placed (the command line
    and ``oimi check`` list them all)."""
    context: str = ""
    """The offending source line with a caret under the column, when known (shown under
    the message)."""

    def __init__(self, message: str, *, source: str = "<input>", line: int = 0, column: int = 0):
        message = _LONG_WORD.sub(_cut, message)
        super().__init__(message)
        self.message = message
        self.source = source
        self.line = line
        self.column = column

    def located(self, source: str, line_offset: int = 0, column_offset: int = 0) -> LocatedError:
        """The same error, placed inside a larger text (e.g. a condition inside a script)."""
        line = self.line + line_offset if self.line else line_offset
        column = self.column + column_offset if self.line <= 1 else self.column
        return type(self)(self.message, source=source, line=line, column=column)

    def __str__(self) -> str:
        if self.line:
            return f"{self.source}:{self.line}:{self.column}: {self.message}"
        return f"{self.source}: {self.message}"


def named(thing: object) -> str:
    """A user's function or class by its qualified name (its repr may hold an address)."""
    return str(getattr(thing, "__qualname__", type(thing).__qualname__))


class Overrun(BaseException):
    """Raised into a user's code that held a tick far past its time (a loop that does not
    end), by the watchdog of the edge that ticks the pipeline (the core keeps no clock).
    Not an ``Exception``, so that the user's own ``except Exception`` does not keep the
    loop going; the pipeline's guards catch :data:`FAILURES` and treat it as any other
    failure of that code."""

    def __init__(self, *args: object) -> None:
        super().__init__(*(args or ("did not return in time",)))


FAILURES: Final = (Exception, Overrun)
"""What a guard around a user's code catches."""


def failure(error: BaseException) -> str:
    """What a user's code (a function, rule body or generator) raised, for a report:
    ``RuntimeError: boom (my_rules.py:18)``, placed at the innermost frame outside the
    pipeline, by file name only, and with memory addresses masked: the text is the same on
    every machine and in every run, and does not move when the pipeline's own code does.
    An :class:`Overrun` lands wherever the loop happened to be: it is placed at the
    function the pipeline called instead (``(in Forever.body, my_rules.py:12)``, the line
    of its ``def``), so that a replay reports it alike."""
    said = _ADDRESS.sub("0x…", str(error))
    text = f"{type(error).__name__}: {said}" if said else type(error).__name__
    theirs = [
        (frame.f_code, line)
        for frame, line in traceback.walk_tb(error.__traceback__)
        if not frame.f_code.co_filename.startswith(_PIPELINE)
    ]
    if not theirs:
        return text
    if isinstance(error, Overrun):
        return f"{text} ({defined_at(theirs[0][0])})"
    code, line = theirs[-1]
    return f"{text} ({os.path.basename(code.co_filename)}:{line})"


def defined_at(code: object) -> str:
    """Where a user's function is defined: ``in child_near, functions.py:9`` (its qualified
    name, its file's base name and the line its definition starts at, its first decorator's
    if any); empty for one without Python code (a builtin, a compiled function)."""
    code = getattr(code, "__code__", code)
    if not hasattr(code, "co_firstlineno"):
        return ""
    where = f"{os.path.basename(code.co_filename)}:{code.co_firstlineno}"  # type: ignore[attr-defined]
    return f"in {code.co_qualname}, {where}"  # type: ignore[attr-defined]


_PIPELINE: Final = (os.path.dirname(os.path.abspath(__file__)) + os.sep, "pipeline" + os.sep)
"""Where the pipeline's frames come from: its folder, or (compiled) its relative path."""
_ADDRESS: Final = re.compile(r"0x[0-9a-fA-F]{4,}")
