"""Output paths checked before any work: a path that cannot be written is bad input (exit 2).

Every command that writes a file or a folder calls :func:`check_output` on it
first, so that a long run never ends in a traceback because ``-o`` names a
folder, a path under a file, or a read-only place. :func:`output_error` turns an
``OSError`` met while writing into the same error.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path

from oimi.pipeline.errors import LocatedError


class OutputError(LocatedError):
    """An output path that cannot be written; ``source`` is the path."""


def output_error(path: str | os.PathLike[str], error: OSError) -> OutputError:
    """The CLI error for an ``OSError`` raised while writing ``path``."""
    why = error.strerror or str(error)
    where = f" ({error.filename})" if error.filename and str(error.filename) != str(path) else ""
    return OutputError(f"cannot write here: {why}{where}", source=os.fspath(path))


def check_output(
    path: str | os.PathLike[str], *, folder: bool = False, create: bool = False
) -> Path:
    """``path`` as a ``Path`` if it can be written, else raise :class:`OutputError` (exit 2).

    A file (``folder=False``) must not be an existing folder; a folder must not be an
    existing file; an existing file must be writable. The nearest existing parent
    must be a writable folder (missing folders in between are fine: they are made
    when written). ``create`` makes the folder now (``path`` itself for a folder,
    its parent for a file). Nothing else is written.
    """
    target = Path(path)
    if str(path) == "":
        raise OutputError("an empty path", source="''")
    try:
        _check(target, folder=folder)
    except OSError as error:  # a name too long, a loop of links...
        raise output_error(target, error) from None
    if create:
        try:
            (target if folder else target.parent).mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise output_error(target, error) from None
    return target


def _check(target: Path, *, folder: bool) -> None:
    if target.exists():
        if folder and not target.is_dir():
            raise _refuse(target, errno.ENOTDIR)
        if not folder and target.is_dir():
            raise _refuse(target, errno.EISDIR)
        if not os.access(target, os.W_OK | (os.X_OK if folder else 0)):
            raise _refuse(target, errno.EACCES)
    else:
        parent = _existing_parent(target)
        if not parent.is_dir():
            raise _refuse(target, errno.ENOTDIR, parent)
        if not os.access(parent, os.W_OK | os.X_OK):
            raise _refuse(target, errno.EACCES, parent)


def _existing_parent(path: Path) -> Path:
    for parent in path.absolute().parents:
        if parent.exists():
            return parent
    return Path("/")


def _refuse(path: Path, code: int, parent: Path | None = None) -> OutputError:
    where = f" ({parent})" if parent is not None else ""
    return OutputError(f"cannot write here: {os.strerror(code)}{where}", source=str(path))
