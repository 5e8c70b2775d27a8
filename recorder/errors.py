"""The recorder's error base: bad or unreadable recordings, misuse of a sink."""

from __future__ import annotations

from oimi.pipeline.errors import LocatedError


class RecordingError(LocatedError):
    """A recording cannot be written or read; ``source`` names the file."""
