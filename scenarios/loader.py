"""Loading a scenario file: TOML -> strict Structs -> checks, with errors at ``FILE:LINE:COL``.

``load_scenario`` reads the file; ``parse_scenario`` does the work on bytes already
read (for tests and for recordings that carry the file). ``decode_scenario`` is the one
validation of a scenario, for files and ``--param`` overrides alike: every number finite,
the ranges the schema declares, then ``check_scenario`` (places, order, ids, the robot's
ceiling). Errors read ``FILE:LINE:COL: field (unit): what is wrong``, placed on the line
of the offending key by a best-effort scan of the TOML text (``TomlLocator``).

Long module: the one validation of a scenario (issue 15): decoding, the range
checks with units and the located errors share the TOML position scan.
"""

from __future__ import annotations

import functools
import math
import re
import tomllib
import typing
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, Final

import msgspec
from oimi.pipeline.act.safety_config import safety_problems
from oimi.pipeline.messages import Script
from oimi.pipeline.operator.commands import VERBS
from oimi.pipeline.operator.generator import Catalogue, GeneratorError, guarded
from oimi.pipeline.operator.generators import default_catalogue
from oimi.pipeline.operator.handler import generate_script
from oimi.pipeline.plurals import counted
from oimi.pipeline.script.validate import jump_failures
from oimi.pipeline.sense.producer import MAX_ENTITIES
from oimi.pipeline.texts import did_you_mean, meant
from oimi.pipeline.think.conditions import compile_condition
from oimi.pipeline.think.functions import FunctionRegistry
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.extensions import (
    ExtensionError,
    LoadedExtension,
    Toolkit,
    build_toolkit,
    load_extensions,
)
from oimi.scenarios.fields import suggestion
from oimi.scenarios.profile import THESIS_ROBOT
from oimi.scenarios.safety import coverage_gaps, unsafe_assumptions
from oimi.scenarios.schema import (
    ActivitySpec,
    BehaviourEvent,
    BehaviourSegment,
    Custom,
    Event,
    Expectation,
    FaultEvent,
    MinDistance,
    OperatorEvent,
    RuleFired,
    Scenario,
    SensorKind,
    TouchEvent,
    Waypoints,
    unit_of,
)
from oimi.scenarios.session.activities import ACTIVITIES, check_script_file
from oimi.scenarios.session.watchdog import watching
from oimi.scenarios.simulation.humans import make_behaviour

LIBRARY_DIR: Final = Path(__file__).resolve().parent / "library"
"""Where scenario files and their activities ship; scripts are looked up here second."""

SCRIPT_SUFFIXES: Final = (".json", ".txt")

PathKey = tuple[str | int, ...]


class LoadedScenario(msgspec.Struct, frozen=True, kw_only=True):
    """A decoded scenario with where it came from (for recordings and relative paths)."""

    scenario: Scenario
    source: Path
    """The scenario file."""
    raw: bytes
    """The file's bytes, exactly as read."""
    activity_paths: tuple[Path | None, ...]
    """The resolved script file of each activity (None for generators), in order."""
    toolkit: Toolkit = msgspec.field(default_factory=build_toolkit)
    """The built-ins plus the extensions the scenario (and the command line) named."""
    warnings: tuple[ScenarioError, ...] = ()
    """What the scenario may do but should know (``oimi check`` and ``oimi run`` say it):
    a sonar ring too short for the safety supervisor (``scenarios.safety.coverage_gaps``)."""


# ------------------------------------------------------------------ locating


_HEADER = re.compile(r"^\s*(\[\[?)\s*([^\]]+?)\s*\]\]?\s*(#.*)?$")
_KEY = re.compile(r"^(\s*)([A-Za-z0-9_\-\"'. ]+?)\s*=")
_INLINE_KEY = re.compile(r"([A-Za-z0-9_\-]+|\"[^\"]*\"|'[^']*')\s*=")
_SCALAR_END = re.compile(r"[,\]]")
_JSON_PATH_PART = re.compile(r"\.([A-Za-z0-9_\-]+)|\[(\d+)\]")


class TomlLocator:
    """Maps a path in the decoded document (``$.humans[1].x_m``) to a (line, column) of the text.

    Knows ``[table]`` and ``[[array.of.tables]]`` headers, ``key =`` lines, and the
    elements and keys of inline arrays and tables (also over several lines); a
    path it does not know is placed on its deepest known part. Lines and columns
    count from 1. Best effort: it reads TOML the simple way (no multi-line strings).
    """

    def __init__(self, text: str):
        self._places: dict[PathKey, tuple[int, int]] = {}
        counts: dict[PathKey, int] = {}
        table: PathKey = ()
        stack: list[list[Any]] = []  # open inline containers: [bracket, path, next index, last key]
        for number, line in enumerate(text.splitlines(), start=1):
            stripped = _strip_comment(line)
            if not stack and (header := _HEADER.match(stripped)):
                names = _split_key(header.group(2))
                if header.group(1) == "[[":
                    array = (*self._resolve(names[:-1], counts), names[-1])
                    index = counts.get(array, 0)
                    counts[array] = index + 1
                    table = (*array, index)
                else:
                    table = self._resolve(names, counts)
                self._places.setdefault(table, (number, line.index("[") + 1))
                continue
            start = 0
            base: PathKey = table
            if not stack and (key := _KEY.match(stripped)):
                base = (*table, *_split_key(key.group(2)))
                self._places.setdefault(base, (number, len(key.group(1)) + 1))
                start = key.end()
            self._scan_value(stripped, start, number, base, stack)

    def _scan_value(
        self, line: str, start: int, number: int, base: PathKey, stack: list[list[Any]]
    ) -> None:
        """Record the inline elements and keys of a value, keeping open containers in ``stack``."""
        position, quote = start, ""
        while position < len(line):
            char = line[position]
            top = stack[-1] if stack else None
            if quote:
                quote = "" if char == quote else quote
            elif top and top[0] == "{" and (key := _INLINE_KEY.match(line, position)):
                top[3] = key.group(1).strip("\"'")
                self._places.setdefault((*top[1], top[3]), (number, position + 1))
                position = key.end() - 1
            elif char in "[{":
                if top is None:
                    path = base
                elif top[0] == "[":
                    path = (*top[1], top[2])
                    top[2] += 1
                else:
                    path = (*top[1], top[3])
                self._places.setdefault(path, (number, position + 1))
                stack.append([char, path, 0, ""])
            elif char in "]}":
                if stack:
                    stack.pop()
            elif top and top[0] == "[" and not char.isspace() and char != ",":
                # a scalar element: count it so the elements after it keep their index
                self._places.setdefault((*top[1], top[2]), (number, position + 1))
                top[2] += 1
                if char in "\"'":
                    quote = char
                else:
                    end = _SCALAR_END.search(line, position)
                    position = (end.start() if end else len(line)) - 1
            elif char in "\"'":
                quote = char
            position += 1

    def _resolve(self, names: list[str], counts: dict[PathKey, int]) -> PathKey:
        """A header's names with the latest index of every array of tables on the way."""
        path: PathKey = ()
        for name in names:
            path = (*path, name)
            if path in counts:
                path = (*path, counts[path] - 1)
        return path

    def locate(self, path: PathKey) -> tuple[int, int]:
        """Line and column of the deepest known prefix of ``path``; (0, 0) if none."""
        for end in range(len(path), 0, -1):
            if (place := self._places.get(path[:end])) is not None:
                return place
        return (0, 0)

    def locate_json_path(self, text: str) -> tuple[int, int]:
        """Line and column of a msgspec ``$.a[0].b`` path."""
        return self.locate(parse_json_path(text))


def parse_json_path(text: str) -> PathKey:
    """``$.humans[0].x_m`` -> ``("humans", 0, "x_m")``."""
    return tuple(
        name if name else int(index) for name, index in _JSON_PATH_PART.findall(text.lstrip("$"))
    )


def _strip_comment(line: str) -> str:
    return "".join(char for _, char, _ in _characters(line))


def _characters(line: str) -> Iterator[tuple[int, str, bool]]:
    """(index, character, inside a string) for a line up to its comment."""
    quote = ""
    for index, char in enumerate(line):
        if quote:
            quote = "" if char == quote else quote
            yield index, char, True
        elif char in "\"'":
            quote = char
            yield index, char, True
        elif char == "#":
            return
        else:
            yield index, char, False


def _split_key(key: str) -> list[str]:
    return [part.strip().strip("\"'") for part in key.split(".")]


# ------------------------------------------------------------------- loading


class Invalid(Exception):
    """One problem of a scenario: where in the document and what is wrong."""

    def __init__(self, where: PathKey, what: str):
        super().__init__(what)
        self.where = where
        self.what = what
        self.others: tuple[Invalid, ...] = ()
        """The scenario's other problems found with this one."""

    def message(self) -> str:
        """``field (unit): what is wrong``."""
        field = field_name(self.where)
        names = [part for part in self.where if isinstance(part, str)]
        unit = unit_of(names[-1]) if names else ""
        label = f"{field} ({unit})" if unit else field
        return f"{label}: {self.what}" if label else self.what


def field_name(where: PathKey) -> str:
    """``("humans", 0, "x_m")`` -> ``humans[0].x_m``."""
    text = ""
    for part in where:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else part)
    return text


def load_scenario(
    path: str | Path,
    *,
    catalogue: Catalogue | None = None,
    allow_outside: bool = False,
    extensions: Sequence[str] = (),
) -> LoadedScenario:
    """Read, decode and check a scenario file (see :func:`parse_scenario`).

    Raises ``ScenarioError`` (``FILE:LINE:COL: field (unit): message``) on any problem.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as error:
        raise ScenarioError(
            f"cannot read the scenario: {error.strerror}", source=str(path)
        ) from None
    return parse_scenario(
        raw, source=path, catalogue=catalogue, allow_outside=allow_outside, extensions=extensions
    )


def parse_scenario(
    raw: bytes,
    *,
    source: str | Path = "<scenario>",
    base_dir: Path | None = None,
    catalogue: Catalogue | None = None,
    allow_outside: bool = False,
    extensions: Sequence[str] = (),
    loaded_extensions: Sequence[LoadedExtension] | None = None,
) -> LoadedScenario:
    """Decode and check a scenario from its bytes: everything ``oimi run`` would refuse.

    Its ``extensions`` (relative to its folder) and ``extensions`` given here (module
    names or paths, e.g. ``--extension``) are loaded with the installed ones into the
    scenario's :class:`~scenarios.extensions.Toolkit`; ``loaded_extensions`` replaces
    that loading (a replay hands the recording's own).

    Scripts resolve against ``base_dir`` (default: the folder of ``source``), then the
    library; outside those two only when ``allow_outside``. Every script must parse and
    its conditions compile; generators and their options are checked against
    ``catalogue`` (default: the shipped generators plus the scenario's scripts).
    """
    source_path = Path(source)
    name = str(source)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as error:
        raise ScenarioError(f"not UTF-8 text: {error.reason}", source=name) from None
    document = _parse_toml(text, name)
    locator = TomlLocator(text)
    folder = base_dir if base_dir is not None else source_path.parent
    try:
        scenario = decode_scenario(document)
        if loaded_extensions is None:
            try:
                loaded_extensions = [
                    *load_extensions(scenario.extensions, base=folder, installed=False),
                    *load_extensions(extensions),  # the command line's: from the cwd
                ]
            except ExtensionError as error:
                raise Invalid(("extensions",), error.message) from None
        toolkit = build_toolkit(loaded_extensions)
        _check_behaviours(scenario, toolkit)
        paths, scripts = _check_activities(scenario, folder, catalogue, allow_outside, toolkit)
        _check_expected_names(
            scenario, scripts, (folder, folder / "activities", *toolkit.activity_folders)
        )
    except Invalid as problem:
        errors = [located(each, name, locator) for each in (problem, *problem.others)]
        raise first_of(errors) from None
    except ExtensionError as error:
        line, column = locator.locate(("extensions",))
        raise ScenarioError(error.message, source=name, line=line, column=column) from None
    return LoadedScenario(
        scenario=scenario,
        source=source_path,
        raw=raw,
        activity_paths=tuple(paths),
        toolkit=toolkit,
        warnings=tuple(
            located(Invalid(where, what), name, locator) for where, what in coverage_gaps(scenario)
        ),
    )


def first_of(errors: list[ScenarioError]) -> ScenarioError:
    """The first of ``errors``, carrying the others (``also``)."""
    errors[0].also = tuple(errors[1:])
    return errors[0]


def located(problem: Invalid, source: str, locator: TomlLocator) -> ScenarioError:
    """``problem`` at its line and column of the file."""
    line, column = locator.locate(problem.where)
    return ScenarioError(problem.message(), source=source, line=line, column=column)


def _check_behaviours(scenario: Scenario, toolkit: Toolkit) -> None:
    """Every ``custom`` segment names a behaviour an extension added, which its options
    make (as the world will: a factory that raises is refused here)."""
    known = ", ".join(sorted(toolkit.behaviours)) or "none: add an extension"
    segments: list[tuple[PathKey, str, object]] = [
        (("humans", h, "behaviour", n), human.id, segment)
        for h, human in enumerate(scenario.humans)
        for n, segment in enumerate(human.behaviour)
    ]
    segments += [
        (("events", n, "segment"), event.human, event.segment)
        for n, event in enumerate(scenario.events)
        if isinstance(event, BehaviourEvent)
    ]
    for where, human, segment in segments:
        if not isinstance(segment, Custom):
            continue
        if segment.name not in toolkit.behaviours:
            raise Invalid((*where, "name"), f"unknown behaviour {segment.name!r} (known: {known})")
        try:
            with watching():  # a factory in a loop that does not end is stopped
                make_behaviour(segment, toolkit.behaviours, human)
        except ScenarioError as error:
            raise Invalid((*where, "options"), f"{error.source}: {error.message}") from None


def decode_scenario(document: Any) -> Scenario:
    """The one validation of a scenario (files and overrides): every number finite, then
    the schema's types and ranges, then :func:`check_scenario`. Raises the first
    ``Invalid`` with the others of its stage (every number that is not finite, or every
    problem of the checks; the schema reports its first)."""
    problems = [
        Invalid(where, f"must be a finite number, got {value!r}")
        for where, value in _non_finite(document, ())
    ]
    if not problems:
        try:
            scenario = msgspec.convert(document, Scenario)
        except msgspec.ValidationError as error:
            raise _invalid(str(error), document) from None
        problems = [Invalid(where, what) for where, what in check_scenario(scenario)]
    if problems:
        first = problems[0]
        first.others = tuple(problems[1:])
        raise first
    return scenario


def _non_finite(node: Any, where: PathKey) -> Iterator[tuple[PathKey, float]]:
    if isinstance(node, float) and not math.isfinite(node):
        yield where, node
    elif isinstance(node, dict):
        for key, value in node.items():
            yield from _non_finite(value, (*where, key))
    elif isinstance(node, list | tuple):
        for index, value in enumerate(node):
            yield from _non_finite(value, (*where, index))


MAX_NESTING: Final = 32
"""Deepest nesting of inline arrays and tables in a scenario file (the schema needs 3)."""

_OUT_OF_RANGE = re.compile(r"Expected `(\w+)` (>=|>|<=|<) (\S+)$")


def _parse_toml(text: str, source: str) -> dict[str, Any]:
    if (deep := _too_deep(text)) is not None:
        raise ScenarioError(
            f"TOML: nested deeper than {MAX_NESTING} levels",
            source=source,
            line=deep[0],
            column=deep[1],
        )
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        message = str(error)
        match = re.search(r"\s*\(at line (\d+), column (\d+)\)$", message)
        if match:
            raise ScenarioError(
                f"TOML: {message[: match.start()]}",
                source=source,
                line=int(match.group(1)),
                column=int(match.group(2)),
            ) from None
        line = max(1, text.count("\n") + 1)
        raise ScenarioError(
            f"TOML: {re.sub(r' [(]at end of document[)]$', '', message)}",
            source=source,
            line=line,
        ) from None


def _too_deep(text: str) -> tuple[int, int] | None:
    """Line and column of the first bracket nested deeper than ``MAX_NESTING`` (outside
    strings and comments), or None; ``tomllib`` would recurse on it without limit."""
    depth = 0
    for number, line in enumerate(text.splitlines(), start=1):
        for index, char, quoted in _characters(line):
            if quoted:
                continue
            if char in "[{":
                depth += 1
                if depth > MAX_NESTING:
                    return number, index + 1
            elif char in "]}":
                depth = max(0, depth - 1)
    return None


def _invalid(message: str, document: Any) -> Invalid:
    """A msgspec error as ``Invalid``: the path it names, and what is wrong with the value."""
    text, _, path_text = message.partition(" - at ")
    path = parse_json_path(path_text.strip("`") or "$")
    if unknown := re.match(r"Object contains unknown field `([^`]+)`", text):
        key = unknown.group(1)
        hint = _OPERATOR_HINT if key == "verb" else suggestion(key, path, document)
        return Invalid((*path, key), "unknown field" + hint)
    if missing := re.match(r"Object missing required field `([^`]+)`", text):
        return Invalid((*path, missing.group(1)), "required, but missing")
    if bound := _OUT_OF_RANGE.match(text):
        return Invalid(
            path, f"must be {bound.group(2)} {bound.group(3)}, got {_value(document, path)}"
        )
    if text.startswith("Invalid value") and (known := _choices(path)):
        return Invalid(path, f"{text} (one of {', '.join(known)})")
    return Invalid(path, text)


def _choices(path: PathKey) -> tuple[str, ...]:
    """The values a tag at ``path`` takes: an operator command's ``cmd``, a behaviour
    segment's, an event's or an expectation's ``kind`` (none for any other path)."""
    if path[-1:] == ("cmd",):
        return tuple(VERBS)
    if path[-1:] != ("kind",):
        return ()
    owner = next((part for part in reversed(path[:-1]) if isinstance(part, str)), "")
    union = _KINDS.get(owner)
    return tuple(kind.__struct_config__.tag for kind in typing.get_args(union)) if union else ()


_KINDS: Final = {
    "behaviour": BehaviourSegment,
    "segment": BehaviourSegment,
    "events": Event,
    "expect": Expectation,
}
"""The tagged unions by the key that holds them in a scenario file."""


_OPERATOR_HINT: Final = (
    '; an operator event holds its command: command = { cmd = "start" } (docs/scenario-files.md)'
)


def _value(document: Any, path: PathKey) -> str:
    node = document
    for part in path:
        try:
            node = node[part]
        except (KeyError, IndexError, TypeError):
            return "?"
    return repr(node)


def _located_validation_error(message: str, source: str, locator: TomlLocator) -> ScenarioError:
    path_text = message.rsplit(" - at ", 1)[1].strip("`") if " - at " in message else "$"
    path = parse_json_path(path_text)
    unknown = re.match(r"Object contains unknown field `([^`]+)`", message)
    if unknown:
        path = (*path, unknown.group(1))
    line, column = locator.locate(path)
    return ScenarioError(message, source=source, line=line, column=column)


def _check_activities(
    scenario: Scenario,
    folder: Path,
    catalogue: Catalogue | None,
    allow_outside: bool,
    toolkit: Toolkit,
) -> tuple[list[Path | None], list[Script]]:
    """Each activity's script file (None for a generator), found, confined and compiled;
    then every generator and its options, as the session will start them. Returns the
    files and the scripts (the files' and the generators')."""
    paths: list[Path | None] = []
    scripts: dict[str, Script] = {}
    shipped = default_catalogue().names()
    for index, activity in enumerate(scenario.activities):
        where: PathKey = ("activities", index)
        if (activity.script is None) == (activity.generator is None):
            raise Invalid(where, "an activity needs exactly one of `script` or `generator`")
        if activity.script is None:
            paths.append(None)
            continue
        path = _find_script(
            activity.script, (*where, "script"), folder, allow_outside, toolkit.activity_folders
        )
        parsed, errors = check_script_file(path, functions=toolkit.registries.functions)
        if parsed is None or errors:
            raise Invalid((*where, "script"), f"{activity.script!r} does not load: {errors[0]}")
        name = parsed.script.activityname
        if catalogue is None and name in shipped:
            raise Invalid(
                (*where, "script"),
                f"{activity.script!r} names its activity {name!r}, a shipped generator's name",
            )
        scripts[name] = parsed.script
        paths.append(path)
    if catalogue is None:
        catalogue = toolkit.registries.catalogue(scripts)
    generated = [
        _check_generator(catalogue, activity, index, toolkit.registries.functions)
        for index, activity in enumerate(scenario.activities)
        if activity.generator is not None
    ]
    return paths, [*scripts.values(), *generated]


def _check_expected_names(
    scenario: Scenario, scripts: Sequence[Script], folders: Sequence[Path]
) -> None:
    """An expectation naming a rule no script loads, an activity no script is, or a goal
    no script has, whose name is close to one that a script does, is a typo (``at_most =
    0`` would pass forever; ``completed never`` would say nothing of why): refused. The
    scenario's scripts are looked at first, then every script of its activity folders and
    the library; a name like none of them is left alone (a generator may make it)."""
    expected = [(n, key, name) for n, e in enumerate(scenario.expect) for key, name in _named(e)]
    known = _names(scripts)
    missing = [(n, key, name) for n, key, name in expected if name not in known[key]]
    if not missing:
        return
    for folder in (*folders, ACTIVITIES):
        for path in sorted([*folder.glob("*.json"), *folder.glob("*.txt")]):
            parsed, _ = check_script_file(path)
            if parsed is not None:
                for key, names in _names([parsed.script]).items():
                    known[key] |= names
    typos = [
        Invalid(("expect", index, key), f"no script {_HAS[key]} {key} {name!r}{hint}")
        for index, key, name in missing
        if name not in known[key] and (hint := did_you_mean(name, sorted(known[key])))
    ]
    if typos:
        typos[0].others = tuple(typos[1:])
        raise typos[0]


_HAS: Final = {"rule": "loads a", "activity": "is an", "goal": "has a"}
"""How an expectation's named thing belongs to a script, by its key."""


def _named(expectation: Any) -> list[tuple[str, str]]:
    """The rule, activity and goal an expectation names, by its key."""
    return [(key, getattr(expectation, key)) for key in _HAS if hasattr(expectation, key)]


def _names(scripts: Iterable[Script]) -> dict[str, set[str]]:
    """The rules the scripts' alfa and omega messages name, the scripts' activities and
    their goals, by an expectation's key."""
    scripts = list(scripts)
    return {
        "rule": {m.id for s in scripts for m in (*s.alfarulemessages, *s.omegarulemessages)},
        "activity": {s.activityname for s in scripts},
        "goal": {g.goalid for s in scripts for g in s.goals},
    }


def _find_script(
    name: str, where: PathKey, folder: Path, allow_outside: bool, extra: Sequence[Path] = ()
) -> Path:
    """The script file ``name``: in ``folder``, else in the library, else in the extensions'
    activity folders; confined to those unless ``allow_outside``."""
    script = Path(name)
    if script.suffix not in SCRIPT_SUFFIXES:
        found = [  # the file meant, as the scenario would name it
            f"{under}{name}{suffix}"
            for root in (folder, LIBRARY_DIR, *extra)
            for under in ("", "activities/")
            for suffix in SCRIPT_SUFFIXES
            if (root / f"{under}{name}{suffix}").is_file()
        ]
        hint = meant(found[0]) if found else ""
        raise Invalid(where, f"script {name!r} is not a .json or .txt file{hint}")
    roots = (folder.resolve(), LIBRARY_DIR.resolve(), *(p.resolve() for p in extra))
    for candidate in (folder / script, LIBRARY_DIR / script, *(p / script for p in extra)):
        resolved = candidate.resolve()
        inside = any(resolved.is_relative_to(root) for root in roots)
        if not inside and not allow_outside:
            raise Invalid(
                where,
                f"script {name!r} is outside the scenario's folder and the library"
                " (--allow-outside-paths allows it)",
            )
        if resolved.is_file():
            return candidate
    near = [
        p.name for root in (folder, LIBRARY_DIR, *extra) for p in _scripts_in(root / script.parent)
    ]
    hint = did_you_mean(script.name, near, shown=lambda name: repr(str(script.with_name(name))))
    raise Invalid(
        where,
        f"script file {name!r} not found in the scenario's folder ({folder.resolve()}) nor in"
        f" the library ({LIBRARY_DIR}){hint}",
    )


def _scripts_in(folder: Path) -> list[Path]:
    """The script files (``.txt``, ``.json``) directly in ``folder`` (none if it is not one)."""
    if not folder.is_dir():
        return []
    return sorted(p for p in folder.iterdir() if p.suffix in SCRIPT_SUFFIXES and p.is_file())


def _check_generator(
    catalogue: Catalogue, activity: ActivitySpec, index: int, functions: FunctionRegistry
) -> Script:
    """The script the activity's generator makes at Get Ready (without a map), its jump
    conditions compiled against ``functions`` as the Block Reader will load it."""
    where: PathKey = ("activities", index)
    name, options = typing.cast(str, activity.generator), activity.options
    if name not in catalogue:
        known = ", ".join(sorted(catalogue.names())) or "none"
        raise Invalid((*where, "generator"), f"unknown generator {name!r} (known: {known})")
    try:  # as Get Ready would (without a map): what it raises or returns is checked
        with watching():  # and a loop that does not end stopped, as in a tick
            generator = guarded(name, "create", catalogue.create, name)
            script = generate_script(name, generator, options, None)
    except GeneratorError as error:
        if error.option in options:
            place: PathKey = (*where, "options", error.option)
        else:  # a bad option, or the generator failed
            place = (*where, "options" if error.option else "generator")
        raise Invalid(place, f"generator {name!r}: {error.message}") from None
    compile_jump = functools.partial(compile_condition, registry=functions)
    for path, error in jump_failures(script, compile_jump):  # else it would never load
        raise Invalid(
            (*where, "generator"),
            f"generator {name!r} made a script that does not load: the jump at {path}:"
            f" {error.message} (column {error.column} of its condition)",
        )
    return script


# ------------------------------------------------------------------- checking


def check_scenario(scenario: Scenario) -> Iterator[tuple[PathKey, str]]:
    """Every problem the schema's ranges cannot express, as (path in the file, what is
    wrong), in order: places inside the arena, time order, references, the ceiling."""
    whole_ms = scenario.tick_hz > 0 and not 1000 % scenario.tick_hz
    if not whole_ms:  # a Scenario built in code: a file's is at least 1 (the schema's)
        yield ("tick_hz",), f"{scenario.tick_hz} must divide 1000 (whole-ms ticks)"
    world = scenario.world
    yield from _check_ids(scenario)

    def outside(x: float, y: float, margin: float = 0.0) -> str:
        """Empty inside the arena (``margin`` from its walls), else where and the arena's span."""
        width, height = world.width_m - margin, world.height_m - margin
        if margin <= x <= width and margin <= y <= height:
            return ""
        radius = ", for its radius" if margin else ""
        return (
            f"at ({x:g}, {y:g}), outside the arena (x {margin:g} to {width:g} m, y {margin:g}"
            f" to {height:g} m{radius})"
        )

    robot = scenario.robot
    for name, ceiling in THESIS_ROBOT.ceilings().items():
        if (value := getattr(robot, name)) > ceiling:
            yield (
                ("robot", name),
                f"{value!r} is above the {THESIS_ROBOT.name}'s ceiling of {ceiling!r}"
                f" {unit_of(name)} (scenarios/profile.py)",
            )
    for name, message in safety_problems(robot.safety):
        yield ("robot", "safety", name), message
    if whole_ms:  # what the safety layer needs is counted in ticks
        yield from unsafe_assumptions(scenario)
    rx = robot.x_m if robot.x_m is not None else world.width_m / 2
    ry = robot.y_m if robot.y_m is not None else world.height_m / 2
    if off := outside(rx, ry, robot.radius_m):
        yield ("robot", "x_m"), f"the robot starts {off}"

    beams = scenario.sensors.sonar_beams  # a real ring may report a human in every beam
    room = MAX_ENTITIES - len(scenario.humans) * max(beams, 1)  # each echo an obstacle
    if len(world.obstacles) > room:
        where = f" in each of its {beams} beams" if beams else ""
        yield (
            ("world", "obstacles", max(room, 0)),
            f"{counted(len(world.obstacles), 'obstacle')} and"
            f" {counted(len(scenario.humans), 'human')}: the sonar ring reports each as an"
            f" obstacle{where}, more than the map holds ({MAX_ENTITIES})",
        )
    if len(world.objects) > MAX_ENTITIES:
        yield (
            ("world", "objects", MAX_ENTITIES),
            f"{counted(len(world.objects), 'object')}: more than the map holds ({MAX_ENTITIES})",
        )
    for index, obstacle in enumerate(world.obstacles):
        where = ("world", "obstacles", index)
        if obstacle.radius_m <= 0 and (obstacle.width_m <= 0 or obstacle.height_m <= 0):
            yield where, f"obstacle {obstacle.id!r} needs radius_m, or width_m and height_m"
        if off := outside(obstacle.x_m, obstacle.y_m):
            yield (*where, "x_m"), f"obstacle {obstacle.id!r} is {off}"
    for index, thing in enumerate(world.objects):
        where = ("world", "objects", index)
        if off := outside(thing.x_m, thing.y_m, thing.radius_m):
            yield (*where, "x_m"), f"object {thing.id!r} is {off}"

    for index, human in enumerate(scenario.humans):
        where = ("humans", index)
        if off := outside(human.x_m, human.y_m):
            yield (*where, "x_m"), f"human {human.id!r} starts {off}"
        apart = math.hypot(human.x_m - rx, human.y_m - ry)
        if apart < robot.radius_m + human.radius_m:
            yield (
                (*where, "x_m"),
                f"human {human.id!r} starts inside the robot ({apart:.3g} m between their"
                f" centres, less than their radii {robot.radius_m + human.radius_m:.3g} m)",
            )
        previous = 0.0
        for number, segment in enumerate(human.behaviour):
            spot = (*where, "behaviour", number)
            if segment.at_s < previous:
                yield (
                    (*spot, "at_s"),
                    (
                        f"human {human.id!r}: behaviour segments must be in time order "
                        f"({segment.at_s} s after {previous} s)"
                    ),
                )
            previous = segment.at_s
            if segment.at_s > scenario.duration_s:
                yield (
                    (*spot, "at_s"),
                    (
                        f"human {human.id!r}: segment at {segment.at_s} s is after the end "
                        f"({scenario.duration_s} s)"
                    ),
                )
            yield from _check_segment(segment, spot, human.id, outside)

    humans = [human.id for human in scenario.humans]
    ids = {
        SensorKind.CAMERA: scenario.sensors.camera_id,
        SensorKind.SONAR: scenario.sensors.sonar_id,
    }
    for index, event in enumerate(scenario.events):
        where = ("events", index)
        if event.at_s > scenario.duration_s:
            yield (
                (*where, "at_s"),
                (f"event at {event.at_s} s is outside the session (0 to {scenario.duration_s} s)"),
            )
        if isinstance(event, TouchEvent | BehaviourEvent) and event.human not in humans:
            yield (*where, "human"), f"event names an unknown human {event.human!r}"
        if isinstance(event, OperatorEvent) and event.command.id != 0:
            yield (*where, "command", "id"), "the session numbers the commands: leave id out"
        if isinstance(event, BehaviourEvent):
            yield from _check_segment(event.segment, (*where, "segment"), event.human, outside)
        if isinstance(event, FaultEvent) and event.id is not None and event.id != ids[event.sensor]:
            yield (
                (*where, "id"),
                (f"no {event.sensor} with id {event.id!r} (it is {ids[event.sensor]!r})"),
            )
    for index, expectation in enumerate(scenario.expect):
        if (
            isinstance(expectation, MinDistance)
            and expectation.human is not None
            and expectation.human not in humans
        ):
            yield (
                ("expect", index, "human"),
                (f"expectation names an unknown human {expectation.human!r}"),
            )
        if (
            isinstance(expectation, RuleFired)
            and expectation.at_most is not None
            and expectation.at_most < expectation.at_least
        ):
            yield (
                ("expect", index, "at_most"),
                f"{expectation.at_most} is less than at_least ({expectation.at_least})",
            )
        if (
            isinstance(expectation, RuleFired)
            and expectation.after_s is not None
            and expectation.by_s is not None
            and expectation.by_s < expectation.after_s
        ):
            yield (
                ("expect", index, "by_s"),
                f"{expectation.by_s} is before after_s ({expectation.after_s})",
            )


def _check_ids(scenario: Scenario) -> Iterator[tuple[PathKey, str]]:
    seen: dict[str, PathKey] = {"robot": ("robot",)}
    entries: list[tuple[PathKey, str]] = [
        *((("world", "obstacles", i, "id"), o.id) for i, o in enumerate(scenario.world.obstacles)),
        *((("world", "objects", i, "id"), o.id) for i, o in enumerate(scenario.world.objects)),
        *((("humans", i, "id"), h.id) for i, h in enumerate(scenario.humans)),
    ]
    for where, ident in entries:
        if not ident or "/" in ident:
            yield where, f"id {ident!r} must be non-empty and contain no '/'"
        elif ident in seen:
            yield where, f"duplicate id {ident!r}"
        seen.setdefault(ident, where)


def _check_segment(
    segment: Any, where: PathKey, human: str, outside: Any
) -> Iterator[tuple[PathKey, str]]:
    if isinstance(segment, Waypoints):
        if not segment.waypoints:
            yield (*where, "waypoints"), f"human {human!r}: waypoints is empty"
        for number, (x, y) in enumerate(segment.waypoints):
            if off := outside(x, y):
                yield (*where, "waypoints", number), f"human {human!r}: waypoint {number} is {off}"


# ------------------------------------------------------------------ overrides


def apply_overrides(scenario: Scenario, overrides: Mapping[str, str]) -> Scenario:
    """The scenario with dotted keys replaced: ``{"robot.max_speed_mps": "0.3"}``.

    Keys walk tables by name and lists by index or by an element's ``id``
    (``humans.child.x_m``); values are TOML literals (``0.3``, ``"text"``,
    ``[[1, 2]]``) or bare text, converted to the field's type. The result goes
    through the same validation as a file (:func:`decode_scenario`: ranges, the
    robot's ceiling); errors name the field.
    """
    document = msgspec.to_builtins(scenario)
    for key, value in overrides.items():
        _set_path(document, key, _toml_value(value))
    try:
        return decode_scenario(document)
    except Invalid as problem:
        raise ScenarioError(f"override: {problem.message()}", source="<overrides>") from None


def warnings_with(
    loaded: LoadedScenario, overrides: Mapping[str, str]
) -> tuple[ScenarioError, ...]:
    """The scenario's warnings once ``overrides`` are applied (a ``--param`` may shorten the
    sonar ring or speed the robot up): one about a field an override set is said of the
    overrides, the others are located in the file and name the overrides. Bad overrides
    raise as :func:`apply_overrides` does."""
    if not overrides:
        return loaded.warnings
    given = ", ".join(f"{key}={value}" for key, value in overrides.items())
    locator = TomlLocator(loaded.raw.decode("utf-8"))
    return tuple(
        ScenarioError(Invalid(where, what).message(), source="<overrides>")
        if ".".join(map(str, where)) in overrides
        else located(Invalid(where, f"{what} (with {given})"), str(loaded.source), locator)
        for where, what in coverage_gaps(apply_overrides(loaded.scenario, overrides))
    )


def _toml_value(text: str) -> Any:
    try:
        return tomllib.loads(f"value = {text}")["value"]
    except tomllib.TOMLDecodeError:
        return text


def _set_path(document: dict[str, Any], key: str, value: Any) -> None:
    parts = key.split(".")
    node: Any = document
    for depth, part in enumerate(parts):
        last = depth == len(parts) - 1
        if isinstance(node, dict):
            if part not in node:
                raise ScenarioError(f"override {key!r}: no field {part!r}", source="<overrides>")
            if last:
                node[part] = value
            else:
                node = node[part]
        elif isinstance(node, list):
            index = _list_index(node, part)
            if index is None:
                raise ScenarioError(
                    f"override {key!r}: no element {part!r} in the list", source="<overrides>"
                )
            if last:
                node[index] = value
            else:
                node = node[index]
        else:
            raise ScenarioError(
                f"override {key!r}: {'.'.join(parts[:depth])!r} has no fields", source="<overrides>"
            )


def _list_index(items: list[Any], part: str) -> int | None:
    if part.isdigit():
        return int(part) if int(part) < len(items) else None
    for index, item in enumerate(items):
        if isinstance(item, dict) and item.get("id") == part:
            return index
    return None
