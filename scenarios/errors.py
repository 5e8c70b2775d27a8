"""The error of the scenarios package: a bad scenario file, placed at ``FILE:LINE:COL``."""

from __future__ import annotations

from oimi.pipeline.errors import LocatedError


class ScenarioError(LocatedError):
    """A scenario file (or an override of it) that cannot be used, with where and why."""
