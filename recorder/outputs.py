"""Output paths checked before any work: a place that cannot be written is bad input (exit 2).

:func:`check_output` is the one answer to "can this place be written", for every command's
outputs (tables, reports, compiled scripts, saved views) and for recordings, whose own
rules (no overwriting, no leftover partial file) are added by
``scenarios.session.recording.check_outputs``. A long run never ends in a traceback
because ``-o`` names a folder, a path under a file, or a read-only place.
:func:`output_error` turns an ``OSError`` met while writing into the same error.
"""

from __future__ import annotations

import os
from pathlib import Path

from oimi.recorder.errors import RecordingError


class OutputError(RecordingError):
    """An output path that cannot or may not be written; ``source`` is the path."""


def output_error(path: str | os.PathLike[str], error: OSError) -> OutputError:
    """The error for an ``OSError`` raised while writing ``path``."""
    why = error.strerror or str(error)
    where = f" ({error.filename})" if error.filename and str(error.filename) != str(path) else ""
    return OutputError(f"cannot write here: {why}{where}", source=os.fspath(path))


def check_output(
    path: str | os.PathLike[str],
    *,
    folder: bool = False,
    create: bool = False,
    beside: bool = False,
) -> Path:
    """``path`` as a ``Path`` if it can be written, else raise :class:`OutputError`.

    A file (``folder=False``) must not be an existing folder; a folder must not be an
    existing file; an existing file must be writable, or with ``beside`` (a file written
    beside it and renamed into place) its folder. The nearest existing parent must be a
    writable folder (missing folders in between are fine: they are made when written).
    ``create`` makes the folder now (``path`` itself for a folder, its parent for a file).
    Nothing else is written.
    """
    target = Path(path)
    if str(path) == "":
        raise OutputError("an empty path", source="''")
    try:
        _check(target, folder=folder, beside=beside)
    except OSError as error:  # a name too long, a loop of links...
        raise output_error(target, error) from None
    if create:
        try:
            (target if folder else target.parent).mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise OutputError(
                f"cannot create its folder: {error.strerror or error}", source=str(target)
            ) from None
    return target


def _check(target: Path, *, folder: bool, beside: bool) -> None:
    if target.exists():
        if folder and not target.is_dir():
            raise OutputError("is a file, not a folder", source=str(target))
        if not folder and target.is_dir():
            raise OutputError("is a folder, not a file", source=str(target))
        place = target.parent if beside else target
        if not os.access(place, os.W_OK | (os.X_OK if folder or beside else 0)):
            where = "here" if place == target else f"in {place}"
            raise OutputError(f"cannot write {where}: permission denied", source=str(target))
        return
    parent = _existing_parent(target)
    if not parent.is_dir():
        raise OutputError(f"{parent} is a file, not a folder", source=str(target))
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"cannot write in {parent}: permission denied", source=str(target))


def _existing_parent(path: Path) -> Path:
    for parent in path.absolute().parents:
        if parent.exists():
            return parent
    return Path("/")
