"""The Script package's error: a located error that also names the JSON path."""

from __future__ import annotations

from oimi.pipeline.errors import LocatedError


class ScriptError(LocatedError):
    """Bad script input (JSON or DSL): ``FILE:LINE:COL: message``.

    ``path`` names the place in the Script (``goal0/act0/blk2.truejump``) when known;
    ``context`` is the offending source line with a caret under the column, when known.
    """

    def __init__(
        self,
        message: str,
        *,
        source: str = "<input>",
        line: int = 0,
        column: int = 0,
        path: str = "",
        context: str = "",
    ):
        super().__init__(message, source=source, line=line, column=column)
        self.path = path
        self.context = context

    def located(self, source: str, line_offset: int = 0, column_offset: int = 0) -> ScriptError:
        moved = super().located(source, line_offset, column_offset)
        assert isinstance(moved, ScriptError)
        moved.path = self.path
        return moved
