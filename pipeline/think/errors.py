"""Errors of the rule language: every one names the place (``<condition>:LINE:COL``)."""

from __future__ import annotations

from oimi.pipeline.errors import LocatedError


class RuleSyntaxError(LocatedError):
    """A condition that cannot be loaded: bad syntax, unknown function, class, field or operator."""

    def __init__(
        self, message: str, *, source: str = "<condition>", line: int = 1, column: int = 1
    ):
        super().__init__(message, source=source, line=line, column=column)
