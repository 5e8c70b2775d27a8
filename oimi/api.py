"""oimi's public Python API: what a notebook or a script calls instead of the command line.

Nothing here prints; long work reports through an optional ``progress(tick, total)``.
Errors are the toolkit's located errors (``ScenarioError``, ``ScriptError``,
``RuleSyntaxError``, ``RecordingError``, all ``pipeline.errors.LocatedError``).

    import oimi
    scenario = oimi.load_scenario("examples/bubbles/bubbles.toml")
    outcome = oimi.run(scenario, output="out/bubbles.mcap")
    frames = oimi.open_recording(outcome.recording)
    frames["/rules/decisions"]
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from oimi import console
from oimi.pipeline.errors import LocatedError
from oimi.pipeline.messages import Script, WorldMap
from oimi.pipeline.script import ParsedScript, condition_errors, dump_script_json, parse_script
from oimi.pipeline.think.conditions import Condition, Evaluation, compile_condition
from oimi.recorder.outputs import check_outputs
from oimi.recorder.world_sampling import DEFAULT_WORLD_EVERY_N_TICKS
from oimi.scenarios.checks import check_scenario_file
from oimi.scenarios.extensions import Extension as Extension  # re-exported: the registration API
from oimi.scenarios.extensions import Toolkit, build_toolkit, load_extensions
from oimi.scenarios.loader import LoadedScenario
from oimi.scenarios.loader import load_scenario as _load_scenario
from oimi.scenarios.schema import Scenario as Scenario  # re-exported
from oimi.scenarios.session.recording import recorded
from oimi.scenarios.session.runner import RunResult, Session, Summary

if TYPE_CHECKING:
    from oimi.analysis.load import SessionData

PathLike = str | os.PathLike[str]
Progress = Callable[[int, int], None]
"""Called after each tick with (ticks done, ticks in all)."""


class Watcher(Protocol):
    """A progress display (``oimi run``'s bar): called after each tick like
    :data:`Progress`, and closed when the run ends (Ctrl-C too)."""

    def __call__(self, tick: int, total: int) -> None: ...

    def close(self) -> None: ...


def toolkit(extensions: Sequence[str] = ()) -> Toolkit:
    """The built-in functions, rules, generators and behaviours plus these extensions (module
    names or paths) and the installed ones."""
    return build_toolkit(load_extensions(extensions))


def load_scenario(
    path: PathLike, *, extensions: Sequence[str] = (), allow_outside: bool = False
) -> LoadedScenario:
    """Read and check a scenario file (its scripts, generators, behaviours, extensions);
    raises ``ScenarioError`` (``FILE:LINE:COL: ...``) on any problem."""
    return _load_scenario(path, extensions=extensions, allow_outside=allow_outside)


def check_scenario(path: PathLike, *, extensions: Sequence[str] = ()) -> list[LocatedError]:
    """The problems ``oimi run`` would refuse the scenario for (empty when it is fine)."""
    return check_scenario_file(Path(path), extensions=extensions)


@dataclass(frozen=True)
class RunOutcome:
    """What a run did: its summary, the expectations' verdicts and where it was recorded."""

    result: RunResult
    recording: Path | None

    @property
    def summary(self) -> Summary:
        return self.result.summary

    @property
    def ok(self) -> bool:
        """Every expectation held."""
        return self.result.ok


def run(
    scenario: LoadedScenario | PathLike,
    *,
    output: PathLike | None = None,
    rrd: PathLike | None = None,
    junit: PathLike | None = None,
    seed: int | None = None,
    overrides: Mapping[str, str] | None = None,
    extensions: Sequence[str] = (),
    allow_outside: bool = False,
    overwrite: bool = True,
    realtime: bool = False,
    world_every_n_ticks: int = DEFAULT_WORLD_EVERY_N_TICKS,
    progress: Progress | None = None,
    watch: Callable[[Scenario], Watcher] | None = None,
) -> RunOutcome:
    """Run a scenario faster than real time (``realtime``: paced to the wall clock),
    recording to ``output`` (MCAP) and ``rrd`` (Rerun) when given, and writing the
    expectations as JUnit XML to ``junit``. Every output is checked before anything is
    opened (an existing one is replaced only with ``overwrite``). ``watch`` makes a
    progress display from the scenario as run (after ``overrides``), closed at the end.
    ``world_every_n_ticks``: how often the recording keeps ``/world/state``
    (``recorder.world_sampling``; 1: every tick). Ctrl-C stops the run between two
    ticks (``KeyboardInterrupt``) with the recording finished."""
    started = time.perf_counter()  # the JUnit file's durations; nothing recorded reads it
    loaded = (
        scenario
        if isinstance(scenario, LoadedScenario)
        else load_scenario(scenario, extensions=extensions, allow_outside=allow_outside)
    )
    session = Session(loaded, seed=seed, overrides=overrides)
    mcap, rerun, xml = (None if p is None else Path(p) for p in (output, rrd, junit))
    inputs = (loaded.source, *(p for p in loaded.activity_paths if p is not None))
    check_outputs((mcap, rerun, xml), overwrite=overwrite, inputs=inputs)
    watcher = None if watch is None else watch(session.scenario)
    pace = console.Pacer(session.tick_ms) if realtime else None
    with recorded(
        session,
        mcap=mcap,
        rrd=rerun,
        overwrite=overwrite,
        world_every_n_ticks=world_every_n_ticks,
    ):
        try:
            result = session.run(progress=progress or watcher, pace=pace)
        finally:
            if watcher is not None:
                watcher.close()
    if xml is not None:
        named = loaded.source if isinstance(scenario, LoadedScenario) else Path(scenario)
        took = {named.stem: time.perf_counter() - started}
        console.write_junit(xml, [(named.stem, result)], seconds=took)
    return RunOutcome(result=result, recording=mcap)


def compile_script(
    source: PathLike | bytes, *, extensions: Sequence[str] = (), name: str = "<script>"
) -> Script:
    """A script from a DSL or JSON file (or its bytes), its jump conditions compiled against
    the built-ins plus ``extensions``; raises the first located error."""
    if isinstance(source, bytes):
        data = source
    else:
        name = os.fspath(source)
        data = Path(source).read_bytes()
    parsed: ParsedScript = parse_script(data, source=name)
    functions = toolkit(extensions).registries.functions
    errors = condition_errors(parsed, lambda text: compile_condition(text, registry=functions))
    if errors:
        raise errors[0]
    return parsed.script


def script_json(script: Script) -> str:
    """The thesis's Script JSON of a script (what ``oimi compile`` writes)."""
    return dump_script_json(script)


def condition(text: str, *, extensions: Sequence[str] = ()) -> Condition:
    """A compiled rule condition (raises ``RuleSyntaxError`` with ``<condition>:L:C``)."""
    return compile_condition(text, registry=toolkit(extensions).registries.functions)


def evaluate(
    text: str | Condition,
    world_map: WorldMap,
    *,
    now_ms: int = 0,
    extensions: Sequence[str] = (),
) -> Evaluation:
    """Evaluate a condition once against ``world_map`` (scope-U bindings are written to it)."""
    compiled = text if isinstance(text, Condition) else condition(text, extensions=extensions)
    return compiled.evaluate(world_map, now_ms=now_ms)


def open_recording(path: PathLike, *, topics: Sequence[str] | None = None) -> SessionData:
    """A recording's topics as polars frames (``frames["/rules/decisions"]``),
    with its metadata and attachments."""
    from oimi.analysis.load import load_session

    return load_session(path, topics=topics)
