"""The names a ``script_vect`` update may give (thesis 4.5, table 4.2), checked as text.

A script file is named by a path that must stay inside the script root; a generated script
by ``generator:NAME``. No file is opened here.
"""

from __future__ import annotations

import posixpath
import re
from typing import Final

from oimi.pipeline.messages import GENERATED_SOURCE

ID_RE: Final = re.compile(r"[^\s/\\]+")
"""An entity's ID or an activity's name: no whitespace, '/' or '\\'."""


def check_script_path(path: str, *, script_root: str) -> str | None:
    """Why ``path`` is not an acceptable script path under ``script_root``; None if it is.

    A path must be non-empty, relative, normalised (``posixpath.normpath`` leaves it
    unchanged), free of ``..``, backslashes and control characters, and lie strictly
    inside ``script_root`` (an empty root accepts any such path). No file is touched.
    """
    if not path:
        return "path is empty"
    if _has_control(path):
        return f"path {path!r} contains a control character"
    if "\\" in path:
        return f"path {path!r} contains a backslash"
    if path.startswith("/"):
        return f"path {path!r} is absolute"
    if ".." in path.split("/"):
        return f"path {path!r} contains '..'"
    if posixpath.normpath(path) != path:
        return f"path {path!r} is not normalised (expected {posixpath.normpath(path)!r})"
    if script_root and not path.startswith(script_root + "/"):
        return f"path {path!r} is not inside the script root {script_root!r}"
    return None


def check_script_entry(entry: str, *, script_root: str) -> str | None:
    """Why ``entry`` cannot be in ``script_vect``; None if it can: a script path
    (:func:`check_script_path`) or ``generator:NAME``, a generated script by its activity's
    name (no whitespace, control character, '/' or '\\')."""
    if not entry.startswith(GENERATED_SOURCE):
        return check_script_path(entry, script_root=script_root)
    name = entry.removeprefix(GENERATED_SOURCE)
    if not ID_RE.fullmatch(name) or _has_control(name):
        return (
            f"{entry!r}: bad activity name {name!r} (no whitespace, control character, '/' or '\\')"
        )
    return None


def _has_control(text: str) -> bool:
    return any(ord(c) < 0x20 or ord(c) == 0x7F for c in text)


def check_script_root(script_root: str) -> str:
    """The script root, checked: empty or a normalised relative path; raises ValueError."""
    if script_root in ("", "."):
        return ""
    problem = check_script_path(script_root, script_root="")
    if problem:
        raise ValueError(f"script_root: {problem}")
    return script_root
