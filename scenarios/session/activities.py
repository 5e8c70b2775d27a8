"""Activity scripts on disk: loading a file by its format, and finding scripts by name."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Final

from oimi.pipeline.errors import LocatedError
from oimi.pipeline.messages import Script
from oimi.pipeline.script import ParsedScript, condition_errors
from oimi.pipeline.script.errors import ScriptError
from oimi.pipeline.script.files import parse_script
from oimi.pipeline.think.conditions import compile_condition
from oimi.pipeline.think.functions import FunctionRegistry
from oimi.pipeline.think.reader import ScriptEntry
from oimi.pipeline.think.stdlib import default_registry

LIBRARY: Final = Path(__file__).resolve().parents[1] / "library"
"""The shipped scenarios; their activities are in ``LIBRARY / "activities"``."""
ACTIVITIES: Final = LIBRARY / "activities"
IDLE: Final = "idle_activity"


def load_script_file(path: Path) -> Script:
    """A script from a ``.json`` or DSL ``.txt`` file; ``ScriptError`` names the place."""
    try:
        raw = path.read_bytes()
    except OSError as error:
        raise ScriptError(f"cannot read the script: {error.strerror}", source=str(path)) from None
    return parse_script(raw, source=str(path)).script


def check_script_file(
    path: Path, *, functions: FunctionRegistry | None = None
) -> tuple[ParsedScript | None, list[LocatedError]]:
    """A script file parsed and its jump conditions compiled against ``functions`` (the
    standard library when omitted), as ``oimi run`` would load it: the parsed script (None
    when it does not parse) and every error, placed in the file."""
    try:
        raw = path.read_bytes()
    except OSError as error:
        return None, [ScriptError(f"cannot read the script: {error.strerror}", source=str(path))]
    try:
        parsed = parse_script(raw, source=str(path))
    except ScriptError as error:
        return None, [error]
    registry = functions or default_registry()
    return parsed, condition_errors(parsed, lambda text: compile_condition(text, registry=registry))


class ActivityLibrary:
    """Finds scripts by activity name or relative path in a list of folders (first wins)."""

    def __init__(self, folders: Sequence[Path]) -> None:
        self.folders = tuple(folders)
        self.loaded: dict[Path, Script] = {}
        """Every script file read so far, by resolved path (attached to recordings)."""

    def find(self, name: str) -> Path | None:
        """The file for ``name`` (``x``, ``x.json``, ``activities/x.txt``), or None."""
        candidate = Path(name)
        if candidate.is_absolute() or ".." in candidate.parts:
            return None
        names = (
            [candidate]
            if candidate.suffix
            else [candidate.with_suffix(".json"), candidate.with_suffix(".txt")]
        )
        for folder in self.folders:
            for option in names:
                for path in (folder / option, folder / option.name):
                    if path.is_file():
                        return path.resolve()
        return None

    def load(self, path: Path) -> Script:
        """Load (once) and remember a script file."""
        path = path.resolve()
        if path not in self.loaded:
            self.loaded[path] = load_script_file(path)
        return self.loaded[path]

    def holds_script(self, path: Path) -> bool:
        """Whether ``path`` is a script (loaded, and kept, if so)."""
        try:
            self.load(path)
        except ScriptError:
            return False
        return True

    def resolve(self, name: str) -> ScriptEntry | None:
        """The Block Reader's resolver: a script entry for a name or path, or None."""
        path = self.find(name)
        if path is None:
            return None
        script = self.load(path)
        return ScriptEntry(activity=script.activityname, script=script, source=name)

    def idle(self) -> ScriptEntry:
        """The idle activity (always present in the shipped library)."""
        entry = self.resolve(IDLE)
        if entry is None:
            raise ScriptError("the idle activity is missing", source=str(ACTIVITIES))
        return entry
