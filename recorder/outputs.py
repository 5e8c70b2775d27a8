"""Output paths checked before any work: a place that cannot be written is bad input (exit 2).

:func:`check_output` is the one answer to "can this place be written", for every command's
outputs (tables, reports, compiled scripts, saved views) and for recordings, whose own
rules (no overwriting, no leftover partial file) are added by :func:`check_outputs`. A long
run never ends in a traceback because ``-o`` names a folder, a path under a file, or a
read-only place.
:func:`output_error` turns an ``OSError`` met while writing into the same error.
:func:`check_replace` adds the rules of a command's one output file: never the file it
reads, and not an existing file unless ``--overwrite``.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
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


def check_replace(
    path: str | os.PathLike[str],
    *,
    inputs: Iterable[str | os.PathLike[str]] = (),
    overwrite: bool,
    what: str = "it",
) -> None:
    """Raise :class:`OutputError` for an output that is one of ``inputs`` (the same file,
    by any name or link: refused even with ``overwrite``, since writing it would destroy
    what is read) or, unless ``overwrite``, one that exists (a dangling link too; ``what``
    names it in the message)."""
    target = Path(path)
    for source in inputs:
        if same_file(target, source):
            named = "" if Path(source) == target else f" ({os.fspath(source)})"
            raise OutputError(
                f"is the input file{named}: refusing to write over it, even with --overwrite"
                " (choose another name)",
                source=str(target),
            )
    if not overwrite and (target.exists() or target.is_symlink()):
        raise OutputError(
            f"exists: refusing to replace {what} (pass --overwrite, or choose another name)",
            source=str(target),
        )


def check_outputs(
    paths: Iterable[Path | None], *, overwrite: bool, inputs: Iterable[Path] = ()
) -> None:
    """Refuse, before anything is opened, outputs written through their partial files
    (:func:`claim_partial`): one that cannot be written (:func:`check_output`; missing
    folders are made), one given twice, one that is one of ``inputs`` or whose partial file
    is (even with ``overwrite``), one that exists and one whose partial file exists (a
    killed session's or save's), unless ``overwrite``. An :class:`OutputError` names it."""
    seen: set[Path] = set()
    inputs = tuple(inputs)
    for path in paths:
        if path is None:
            continue
        key = path.absolute()
        if key in seen:
            raise OutputError("given twice as an output", source=str(path))
        seen.add(key)
        check_output(path, create=True, beside=True)
        check_replace(path, inputs=inputs, overwrite=overwrite, what="a recording")
        partial = partial_path(path)
        if any(same_file(partial, source) for source in inputs):
            raise OutputError(
                f"would be written as {partial}, the input file: choose another name",
                source=str(path),
            )
        if not overwrite and (partial.exists() or partial.is_symlink()):
            raise OutputError(
                f"the unfinished file {partial} exists (a killed session or save?):"
                " recover or move it first, or pass --overwrite",
                source=str(path),
            )


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether ``a`` and ``b`` are one file (hard links and symbolic links included), or
    lead to one place when either does not exist."""
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):  # one is missing or unreadable: compare where they lead
        return os.path.realpath(a) == os.path.realpath(b)


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


def partial_path(path: Path) -> Path:
    """Where an output is written until it is complete: ``NAME.partial.mcap`` beside
    ``NAME.mcap``. A killed session leaves this file, which replay recovers."""
    return path.with_name(f"{path.stem}.partial{path.suffix}")


def claim_partial(path: Path, *, overwrite: bool) -> Path:
    """Create ``path``'s partial file exclusively (empty; with ``overwrite`` a leftover one
    is replaced): its path. ``OutputError`` when another writer has it, or it cannot be
    written."""
    partial = partial_path(path)
    try:
        if overwrite:
            partial.unlink(missing_ok=True)
        os.close(os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644))
    except FileExistsError:
        raise OutputError(f"{partial} exists (another writer at work?)", source=str(path)) from None
    except OSError as error:
        raise output_error(path, error) from None
    return partial


def finish_partial(partial: Path, path: Path, *, overwrite: bool) -> None:
    """Give a complete partial file its name; without ``overwrite`` never over another file
    (then the partial file keeps it, and the error says where)."""
    if overwrite:
        os.replace(partial, path)
        return
    appeared = OutputError(
        f"appeared while writing: the output is kept as {partial}", source=str(path)
    )
    try:
        os.link(partial, path)
    except FileExistsError:
        raise appeared from None
    except OSError:  # no hard links on this file system: check, then rename
        if path.exists() or path.is_symlink():
            raise appeared from None
        os.replace(partial, path)
        return
    partial.unlink()
