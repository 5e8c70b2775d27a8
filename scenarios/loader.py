"""Loading a scenario file: TOML -> strict Structs -> checks, with errors at ``FILE:LINE:COL``.

``load_scenario`` reads the file; ``parse_scenario`` does the work on bytes already
read (for tests and for recordings that carry the file). Type errors keep
msgspec's ``$.path`` text and are placed on the line of the offending key by a
best-effort scan of the TOML text (``TomlLocator``).
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Collection, Iterator, Mapping
from pathlib import Path
from typing import Any, Final

import msgspec

from pipeline.act.safety import safety_problems
from scenarios.errors import ScenarioError
from scenarios.schema import (
    Approach,
    BehaviourEvent,
    FaultEvent,
    Follow,
    JoystickEvent,
    MinDistance,
    Scenario,
    SensorKind,
    TouchEvent,
    Waypoints,
)

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
    out, quote = [], ""
    for char in line:
        if quote:
            quote = "" if char == quote else quote
        elif char in "\"'":
            quote = char
        elif char == "#":
            break
        out.append(char)
    return "".join(out)


def _split_key(key: str) -> list[str]:
    return [part.strip().strip("\"'") for part in key.split(".")]


# ------------------------------------------------------------------- loading


def load_scenario(
    path: str | Path, *, known_generators: Collection[str] | None = None
) -> LoadedScenario:
    """Read, decode and check a scenario file.

    ``known_generators``: the generator names an activity may use; None skips that check.
    Raises ``ScenarioError`` (``FILE:LINE:COL: message``) on any problem.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as error:
        raise ScenarioError(
            f"cannot read the scenario: {error.strerror}", source=str(path)
        ) from None
    return parse_scenario(raw, source=path, known_generators=known_generators)


def parse_scenario(
    raw: bytes,
    *,
    source: str | Path = "<scenario>",
    base_dir: Path | None = None,
    known_generators: Collection[str] | None = None,
) -> LoadedScenario:
    """Decode and check a scenario from its bytes; scripts resolve against ``base_dir``.

    ``base_dir`` defaults to the folder of ``source``.
    """
    source_path = Path(source)
    name = str(source)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as error:
        raise ScenarioError(f"not UTF-8 text: {error.reason}", source=name) from None
    document = _parse_toml(text, name)
    locator = TomlLocator(text)
    try:
        scenario = msgspec.convert(document, Scenario)
    except msgspec.ValidationError as error:
        raise _located_validation_error(str(error), name, locator) from None
    problems = list(check_scenario(scenario))
    folder = base_dir if base_dir is not None else source_path.parent
    paths: list[Path | None] = []
    for index, activity in enumerate(scenario.activities):
        resolved, problem = _resolve_activity(index, activity, folder, known_generators)
        paths.append(resolved)
        if problem:
            problems.append(problem)
    if problems:
        where, message = problems[0]
        line, column = locator.locate(where)
        raise ScenarioError(message, source=name, line=line, column=column)
    return LoadedScenario(
        scenario=scenario, source=source_path, raw=raw, activity_paths=tuple(paths)
    )


def _parse_toml(text: str, source: str) -> dict[str, Any]:
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


def _located_validation_error(message: str, source: str, locator: TomlLocator) -> ScenarioError:
    path_text = message.rsplit(" - at ", 1)[1].strip("`") if " - at " in message else "$"
    path = parse_json_path(path_text)
    unknown = re.match(r"Object contains unknown field `([^`]+)`", message)
    if unknown:
        path = (*path, unknown.group(1))
    line, column = locator.locate(path)
    return ScenarioError(message, source=source, line=line, column=column)


def _resolve_activity(
    index: int, activity: Any, folder: Path, known_generators: Collection[str] | None
) -> tuple[Path | None, tuple[PathKey, str] | None]:
    where: PathKey = ("activities", index)
    if (activity.script is None) == (activity.generator is None):
        return None, (where, "an activity needs exactly one of `script` or `generator`")
    if activity.generator is not None:
        if known_generators is not None and activity.generator not in known_generators:
            known = ", ".join(sorted(known_generators)) or "none"
            return None, (
                (*where, "generator"),
                f"unknown generator {activity.generator!r} (known: {known})",
            )
        return None, None
    script = Path(activity.script)
    if script.suffix not in SCRIPT_SUFFIXES:
        return None, ((*where, "script"), f"script {activity.script!r} is not a .json or .txt file")
    for candidate in (folder / script, LIBRARY_DIR / script):
        if candidate.is_file():
            return candidate, None
    return None, (
        (*where, "script"),
        f"script file {activity.script!r} not found in {folder} nor in the library",
    )


# ------------------------------------------------------------------- checking


def check_scenario(scenario: Scenario) -> Iterator[tuple[PathKey, str]]:
    """Every semantic problem of a decoded scenario, as (path in the file, message), in order."""
    if scenario.tick_hz <= 0 or 1000 % scenario.tick_hz:
        yield ("tick_hz",), f"tick_hz {scenario.tick_hz} must divide 1000 (whole-ms ticks)"
    if scenario.duration_s <= 0:
        yield ("duration_s",), "duration_s must be positive"
    world = scenario.world
    if world.width_m <= 0 or world.height_m <= 0:
        yield ("world",), "the arena's width_m and height_m must be positive"
    yield from _check_ids(scenario)

    def outside(x: float, y: float, margin: float = 0.0) -> bool:
        return not (
            margin <= x <= world.width_m - margin and margin <= y <= world.height_m - margin
        )

    robot = scenario.robot
    for name, value in (
        ("radius_m", robot.radius_m),
        ("max_speed_mps", robot.max_speed_mps),
        ("max_angular_speed_radps", robot.max_angular_speed_radps),
        ("max_accel_mps2", robot.max_accel_mps2),
        ("max_angular_accel_radps2", robot.max_angular_accel_radps2),
        ("mass_kg", robot.mass_kg),
    ):
        if value <= 0:
            yield ("robot", name), f"robot {name} must be positive, got {value}"
    for name, message in safety_problems(robot.safety):
        yield ("robot", "safety", name), message
    rx = robot.x_m if robot.x_m is not None else world.width_m / 2
    ry = robot.y_m if robot.y_m is not None else world.height_m / 2
    if outside(rx, ry, robot.radius_m):
        yield ("robot", "x_m"), f"the robot's start ({rx}, {ry}) is outside the arena"

    for index, obstacle in enumerate(world.obstacles):
        where = ("world", "obstacles", index)
        if obstacle.radius_m <= 0 and (obstacle.width_m <= 0 or obstacle.height_m <= 0):
            yield where, f"obstacle {obstacle.id!r} needs radius_m, or width_m and height_m"
        if outside(obstacle.x_m, obstacle.y_m):
            yield (*where, "x_m"), f"obstacle {obstacle.id!r} is outside the arena"
    for index, thing in enumerate(world.objects):
        where = ("world", "objects", index)
        if thing.radius_m <= 0 or thing.mass_kg <= 0:
            yield where, f"object {thing.id!r} needs a positive radius_m and mass_kg"
        if not 0 <= thing.damping_per_s <= 1:
            yield (*where, "damping_per_s"), "damping_per_s must be between 0 and 1"
        if outside(thing.x_m, thing.y_m, thing.radius_m):
            yield (*where, "x_m"), f"object {thing.id!r} is outside the arena"

    for index, human in enumerate(scenario.humans):
        where = ("humans", index)
        if human.radius_m <= 0 or human.max_speed_mps <= 0:
            yield where, f"human {human.id!r} needs a positive radius_m and max_speed_mps"
        if outside(human.x_m, human.y_m):
            yield (*where, "x_m"), f"human {human.id!r} starts outside the arena"
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
        if event.at_s < 0 or event.at_s > scenario.duration_s:
            yield (
                (*where, "at_s"),
                (f"event at {event.at_s} s is outside the session (0 to {scenario.duration_s} s)"),
            )
        if isinstance(event, TouchEvent | BehaviourEvent) and event.human not in humans:
            yield (*where, "human"), f"event names an unknown human {event.human!r}"
        if isinstance(event, BehaviourEvent):
            yield from _check_segment(event.segment, (*where, "segment"), event.human, outside)
        if isinstance(event, FaultEvent) and event.id is not None and event.id != ids[event.sensor]:
            yield (
                (*where, "id"),
                (f"no {event.sensor} with id {event.id!r} (it is {ids[event.sensor]!r})"),
            )
        if isinstance(event, JoystickEvent):
            for axis in ("left_x", "left_y", "right_x"):
                if not -1 <= getattr(event, axis) <= 1:
                    yield (*where, axis), f"joystick {axis} must be between -1 and 1"
        if isinstance(event, TouchEvent) and event.duration_ms < 0:
            yield (*where, "duration_ms"), "duration_ms must not be negative"
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
    if segment.speed_mps is not None and segment.speed_mps <= 0:
        yield (*where, "speed_mps"), f"human {human!r}: speed_mps must be positive"
    if isinstance(segment, Waypoints):
        if not segment.waypoints:
            yield (*where, "waypoints"), f"human {human!r}: waypoints is empty"
        for number, (x, y) in enumerate(segment.waypoints):
            if outside(x, y) or not (math.isfinite(x) and math.isfinite(y)):
                yield (
                    (*where, "waypoints", number),
                    (f"human {human!r}: waypoint ({x}, {y}) is outside the arena"),
                )
    if isinstance(segment, Approach | Follow) and segment.distance_m <= 0:
        yield (*where, "distance_m"), f"human {human!r}: distance_m must be positive"


# ------------------------------------------------------------------ overrides


def apply_overrides(scenario: Scenario, overrides: Mapping[str, str]) -> Scenario:
    """The scenario with dotted keys replaced: ``{"robot.max_speed_mps": "0.3"}``.

    Keys walk tables by name and lists by index or by an element's ``id``
    (``humans.child.x_m``); values are TOML literals (``0.3``, ``"text"``,
    ``[[1, 2]]``) or bare text, converted to the field's type. The result is
    checked like a loaded file; errors name the override.
    """
    document = msgspec.to_builtins(scenario)
    for key, value in overrides.items():
        _set_path(document, key, _toml_value(value))
    try:
        result = msgspec.convert(document, Scenario, strict=False)
    except msgspec.ValidationError as error:
        raise ScenarioError(f"override: {error}", source="<overrides>") from None
    for where, message in check_scenario(result):
        raise ScenarioError(
            f"override: {message} (at {'.'.join(map(str, where))})", source="<overrides>"
        )
    return result


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
