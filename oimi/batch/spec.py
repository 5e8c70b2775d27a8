"""Batch specs: scenarios × parameter grids × seeds, expanded into tasks with stable names.

A batch spec is a TOML file with the keys of :class:`RunGroup` at its top level
and/or any number of ``[[runs]]`` tables, each a group of its own::

    scenarios = ["greeting.toml"]           # relative to the spec file
    seeds = 3                               # the scenario's seed and the 2 after it
    [params]                                # every combination of these values
    "robot.max_speed_mps" = [0.3, 0.5]

Every group expands to scenario × grid combination × seed, in that order. A
task's name is ``STEM[-KEY=VALUE,...]-sSEED`` (a short hash instead of the
overrides when they do not make a tidy file name): the same inputs always give
the same name, so reruns and ``--resume`` find their recordings.
"""

from __future__ import annotations

import itertools
import math
import re
import tomllib
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Annotated, Any

import msgspec

from oimi.analysis.metrics import run_name
from oimi.recorder.world_sampling import DEFAULT_WORLD_EVERY_N_TICKS
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.loader import (
    TomlLocator,
    _located_validation_error,
    load_scenario,
    warnings_with,
)


class SpecError(ScenarioError):
    """A batch spec or a variation option that cannot be used, with where and why."""


class RunGroup(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Scenarios, a parameter grid and seeds: every combination is one run."""

    scenarios: list[str] = []
    """Scenario files (``.toml``) or folders of them, relative to the spec file."""
    params: dict[str, Any] = {}
    """Dotted scenario field -> a list of values (or one value): the grid."""
    seeds: int | None = None
    """Number of seeds: the scenario's own seed and the ones after it."""
    seed_range: str | None = None
    """``"A:B"``: seeds A to B-1 (instead of ``seeds``)."""
    world_every_n_ticks: Annotated[int, msgspec.Meta(ge=1)] | None = None
    """How often each run's recording keeps ``/world/state`` (default every second tick)."""


class BatchSpec(RunGroup, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """A batch file: one group at the top level and/or a list of ``[[runs]]`` groups."""

    runs: list[RunGroup] = []

    def groups(self) -> list[RunGroup]:
        top = RunGroup(
            scenarios=self.scenarios,
            params=self.params,
            seeds=self.seeds,
            seed_range=self.seed_range,
            world_every_n_ticks=self.world_every_n_ticks,
        )
        return ([top] if self.scenarios else []) + list(self.runs)


class Task(msgspec.Struct, frozen=True, kw_only=True):
    """One run: everything that decides its recording (pure input of ``run_task``)."""

    name: str
    """Stable file name stem of the run's outputs."""
    scenario: str
    """The scenario file, absolute."""
    seed: int
    overrides: tuple[tuple[str, str], ...] = ()
    """(dotted key, TOML value text), sorted by key."""
    out_dir: str
    """Where the recording and the result sidecar go."""
    allow_outside_paths: bool = False
    """Scripts may be outside the scenario's folder and the library (``--allow-outside-paths``)."""
    extensions: tuple[str, ...] = ()
    """``--extension`` modules (names, or absolute paths) loaded besides the scenario's own."""
    world_every_n_ticks: int = DEFAULT_WORLD_EVERY_N_TICKS
    """How often the recording keeps ``/world/state`` (``--world-every``)."""

    @property
    def mcap(self) -> Path:
        return Path(self.out_dir) / f"{self.name}.mcap"

    @property
    def result_file(self) -> Path:
        """The finished run's result row (JSON), written after the recording is complete."""
        return Path(self.out_dir) / f"{self.name}.result.json"


# -------------------------------------------------------------------- parsing


def parse_param(text: str, *, source: str = "<command line>") -> tuple[str, str]:
    """``"robot.max_speed_mps=0.3"`` -> ``("robot.max_speed_mps", "0.3")``."""
    key, sep, value = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise SpecError(f"--param {text!r}: expected KEY=VALUE", source=source)
    return key, value.strip()


def parse_seed_range(text: str, *, source: str = "<command line>") -> range:
    """``"A:B"`` -> seeds A to B-1."""
    match = re.fullmatch(r"\s*(-?\d+)\s*:\s*(-?\d+)\s*", text)
    if not match or int(match.group(2)) <= int(match.group(1)):
        raise SpecError(
            f"seed range {text!r}: expected A:B with A < B (seeds A to B-1)", source=source
        )
    return range(int(match.group(1)), int(match.group(2)))


def is_batch_spec(path: Path) -> bool:
    """A TOML file whose top level has ``scenarios`` or ``runs`` (a scenario has neither)."""
    try:
        document = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return False
    return "scenarios" in document or "runs" in document


def load_spec(path: Path) -> BatchSpec:
    """Read and decode a batch spec; errors at ``FILE:LINE:COL``."""
    try:
        text = path.read_text(encoding="utf-8")
        document = tomllib.loads(text)
    except OSError as error:
        raise SpecError(f"cannot read the batch spec: {error.strerror}", source=str(path)) from None
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise SpecError(f"TOML: {error}", source=str(path)) from None
    try:
        return msgspec.convert(document, BatchSpec)
    except msgspec.ValidationError as error:
        # placed like a scenario file's errors (unknown keys on their own line)
        placed = _located_validation_error(str(error), str(path), TomlLocator(text))
        raise SpecError(
            placed.message, source=placed.source, line=placed.line, column=placed.column
        ) from None


# ------------------------------------------------------------------ expanding


def toml_literal(value: Any, *, source: str) -> str:
    """A grid value as the TOML text ``apply_overrides`` reads (numbers, text, booleans, lists)."""
    if _non_finite(value):
        raise SpecError(f"parameter value {value!r} must be a finite number", source=source)
    if isinstance(value, bool | int | float | str) or (
        isinstance(value, list)
        and all(isinstance(v, bool | int | float | str | list) for v in value)
    ):
        return msgspec.json.encode(value).decode()
    raise SpecError(
        f"parameter value {value!r} must be a number, text, boolean or list", source=source
    )


def _non_finite(value: Any) -> bool:
    if isinstance(value, list):
        return any(_non_finite(v) for v in value)
    return isinstance(value, float) and not math.isfinite(value)


def grid(params: Mapping[str, Sequence[str]]) -> list[tuple[tuple[str, str], ...]]:
    """Every combination of the values (key order as given; each combination sorted by key)."""
    keys = list(params)
    return [
        tuple(sorted(zip(keys, values, strict=True)))
        for values in itertools.product(*(params[k] for k in keys))
    ]


def seeds_for(default_seed: int, *, seeds: int | None, seed_range: range | None) -> list[int]:
    if seed_range is not None:
        return list(seed_range)
    return [default_seed + i for i in range(seeds if seeds is not None else 1)]


def task_name(scenario: Path, overrides: Sequence[tuple[str, str]], seed: int) -> str:
    """``greeting-robot.max_speed_mps=0.3-s2`` (``analysis.metrics.run_name``: the name
    ``oimi analyse`` gives the recording; a hash replaces untidy or long overrides)."""
    params = ",".join(f"{k}={v}" for k, v in sorted(overrides))
    return run_name(scenario.stem, params, seed)


def scenario_files(entries: Iterable[str | Path], *, base: Path) -> list[Path]:
    """Scenario files, named or as every ``.toml`` of a folder, resolved against ``base``."""
    files: list[Path] = []
    for entry in entries:
        path = (base / entry).resolve()
        if path.is_dir():
            found = sorted(path.glob("*.toml"))
            if not found:
                raise SpecError("no scenario files (.toml) in this folder", source=str(entry))
            files += found
        else:
            files.append(path)
    return files


def expand(
    scenarios: Sequence[Path],
    *,
    params: Mapping[str, Sequence[str]],
    seeds: int | None,
    seed_range: range | None,
    out_dir: Path,
    allow_outside_paths: bool = False,
    extensions: Sequence[str] = (),
    world_every_n_ticks: int | None = None,
    warn: Callable[[ScenarioError], None] = lambda warning: None,
) -> list[Task]:
    """Every scenario × grid combination × seed as a task. Loads each scenario and applies
    each combination once, so bad files or overrides fail here, before anything runs;
    ``warn`` hears each combination's warnings (``loader.warnings_with``).
    ``world_every_n_ticks``: None for the default sampling (every second tick)."""
    tasks: list[Task] = []
    combos = grid(params)
    for path in scenarios:
        loaded = load_scenario(path, allow_outside=allow_outside_paths, extensions=extensions)
        for combo in combos:
            for warning in warnings_with(loaded, dict(combo)):
                warn(warning)
            for seed in seeds_for(loaded.scenario.seed, seeds=seeds, seed_range=seed_range):
                tasks.append(
                    Task(
                        name=task_name(path, combo, seed),
                        scenario=str(path),
                        seed=seed,
                        overrides=combo,
                        out_dir=str(out_dir),
                        allow_outside_paths=allow_outside_paths,
                        extensions=tuple(extensions),
                        world_every_n_ticks=world_every_n_ticks or DEFAULT_WORLD_EVERY_N_TICKS,
                    )
                )
    return tasks


def expand_spec(
    spec: BatchSpec,
    *,
    source: Path,
    out_dir: Path,
    params: Mapping[str, Sequence[str]] | None = None,
    seeds: int | None = None,
    seed_range: range | None = None,
    allow_outside_paths: bool = False,
    extensions: Sequence[str] = (),
    world_every_n_ticks: int | None = None,
    warn: Callable[[ScenarioError], None] = lambda warning: None,
) -> list[Task]:
    """The tasks of every group of a spec file. ``params`` (TOML value texts) replace the
    groups' values of the same keys; ``seeds`` or ``seed_range`` replace the groups' seeds,
    ``world_every_n_ticks`` their sampling of the world's state; ``warn`` as :func:`expand`."""
    tasks: list[Task] = []
    for group in spec.groups():
        if group.seeds is not None and group.seed_range is not None:
            raise SpecError("give `seeds` or `seed_range`, not both", source=str(source))
        if group.seeds is not None and group.seeds < 1:
            raise SpecError(f"seeds must be at least 1, got {group.seeds}", source=str(source))
        values = {
            key: [
                toml_literal(v, source=str(source))
                for v in (given if isinstance(given, list) else [given])
            ]
            for key, given in group.params.items()
        }
        group_range = (
            parse_seed_range(group.seed_range, source=str(source))
            if group.seed_range is not None
            else None
        )
        if seeds is not None or seed_range is not None:
            group_seeds, group_range = seeds, seed_range
        else:
            group_seeds = group.seeds
        tasks += expand(
            scenario_files(group.scenarios, base=source.parent),
            params={**values, **(params or {})},
            seeds=group_seeds,
            seed_range=group_range,
            out_dir=out_dir,
            allow_outside_paths=allow_outside_paths,
            extensions=extensions,
            world_every_n_ticks=world_every_n_ticks or group.world_every_n_ticks,
            warn=warn,
        )
    if not tasks:
        raise SpecError("the batch spec names no scenarios", source=str(source))
    return tasks


def check_unique(tasks: Sequence[Task]) -> None:
    """Two tasks with one name would overwrite each other's recording."""
    seen: dict[str, Task] = {}
    for task in tasks:
        if (other := seen.setdefault(task.name, task)) is not task:
            if other == task:
                raise SpecError(f"run {task.name!r} is listed twice", source=task.scenario)
            raise SpecError(
                f"runs {other.scenario} and {task.scenario} would both be named {task.name!r}"
                " (rename one scenario file)",
                source=task.scenario,
            )
