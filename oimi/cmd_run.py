"""Run a scenario: world, sensors and the robot's mind, recorded to MCAP (and Rerun).

Every output (MCAP, Rerun, JUnit) is checked before anything is opened: an existing
file is refused unless --overwrite. A recording is written as NAME.partial.mcap and
renamed when closed, so a killed run leaves the partial file (oimi replay recovers it).
Exit 0 when every expectation holds, 1 when one fails, 2 on bad input.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path
from typing import Final

from oimi import api, console, jsonout
from oimi.arg_types import add_world_every_argument
from oimi.batch.spec import parse_param
from oimi.cmd_check import add_outside_paths_argument, report_warnings
from oimi.extension_args import extensions_of
from oimi.pipeline.events import ActivityState
from oimi.pipeline.plurals import counted
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.loader import warnings_with
from oimi.scenarios.session.runner import RunResult

MAX_ERRORS_SHOWN: Final = 5
"""Errors the summary lists (the rest are on ``/log``)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", type=Path, help="scenario file (.toml)")
    parser.add_argument("-o", "--output", type=Path, help="MCAP file (default: out/NAME.mcap)")
    parser.add_argument("--rrd", type=Path, help="also write a Rerun recording here")
    parser.add_argument("--seed", type=int, help="override the scenario's seed")
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scenario field by its dotted path (robot.max_speed_mps=0.3); repeatable",
    )
    parser.add_argument("--realtime", action="store_true", help="pace to the wall clock")
    parser.add_argument("--junit", type=Path, help="write the expectations as JUnit XML")
    parser.add_argument("--no-record", action="store_true", help="do not write an MCAP file")
    add_world_every_argument(parser)
    parser.add_argument(
        "--overwrite", action="store_true", help="replace existing output files (default: refuse)"
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    add_outside_paths_argument(parser)
    jsonout.add_json_argument(parser)


def run(args: argparse.Namespace) -> int:
    output = None if args.no_record else args.output or Path("out") / f"{args.scenario.stem}.mcap"
    extensions = extensions_of(args)
    loaded = api.load_scenario(
        args.scenario, extensions=extensions, allow_outside=args.allow_outside_paths
    )
    overrides = parse_params(args.param)
    report_warnings(warnings_with(loaded, overrides))
    outcome = api.run(
        loaded,
        output=output,
        rrd=args.rrd,
        junit=args.junit,
        seed=args.seed,
        overrides=overrides,
        overwrite=args.overwrite,
        realtime=args.realtime,
        world_every_n_ticks=args.world_every,
        watch=None if args.quiet else console.Progress.of,
    )
    result = outcome.result
    print_result(result)
    if output is not None:
        print(f"recording: {output}")
    if args.rrd is not None:
        print(f"rerun:     {args.rrd}")
    jsonout.emit(
        args,
        {
            "command": "run",
            "ok": result.ok,
            **jsonout.result_summary(result),
            "recording": None if output is None else str(output),
            "rrd": None if args.rrd is None else str(args.rrd),
        },
    )
    return 0 if result.ok else 1


def parse_params(items: Sequence[str]) -> dict[str, str]:
    """``["a.b=1", ...]`` -> ``{"a.b": "1"}``; a key given twice or without ``=`` is bad input."""
    params: dict[str, str] = {}
    for item in items:
        key, value = parse_param(item)
        if key in params:
            raise ScenarioError(f"--param {key!r} given twice", source="<command line>")
        params[key] = value
    return params


def _episodes(episodes: int, fired: int) -> str:
    """`` (3 episodes)`` when a rule's firings came in fewer episodes than firings."""
    if episodes == fired or not episodes:
        return ""
    return f" ({counted(episodes, 'episode')})"


def selected_state(state: str, ran: str | None) -> str:
    """How the summary says a selected activity's ``state``, given its last state on
    ``/reader/progress`` (``ran``, None when it never started): one that never started and
    one that started and was interrupted are both ``not_yet_completed`` to the selection."""
    if ran is None:
        said = "selected" if state == ActivityState.NOT_YET_COMPLETED else state
        return f"{said}, never started"
    if ran == "interrupted" and state == ActivityState.NOT_YET_COMPLETED:
        return f"{state} (started, interrupted)"
    return state


def print_result(result: RunResult, *, live: bool = False) -> None:
    """The end-of-run summary and each expectation's verdict (``live``: a live session's,
    to which the scenario's scripted expectations do not apply)."""
    s = result.summary
    print(f"scenario {s.scenario} (seed {s.seed}): {s.ticks} ticks, {s.duration_s:.1f} s simulated")
    for name, state in s.activities.items():
        print(f"  activity {name}: {selected_state(state, s.ran.get(name))}")
    for name, state in s.ran.items():
        if name not in s.activities:
            print(f"  activity {name}: {state} (no longer selected)")
    for goal, at_ms in s.goals_reached.items():
        print(f"  goal {goal} reached at {at_ms / 1000:.2f} s")
    if s.rules_fired:
        fired = ", ".join(
            f"{rule} x{count}" + _episodes(s.rule_episodes.get(rule, 0), count)
            for rule, count in s.rules_fired.items()
        )
        print(f"  rules fired: {fired}")
    closest = ", ".join(f"{h} {d:.2f} m" for h, d in s.min_surface_distance_m.items())
    pushed = f" {s.pushed_contacts} pushed by another person," if s.pushed_contacts else ""
    print(
        f"  safety: max speed {s.max_speed_mps:.2f} m/s, closest (surface to surface)"
        f" {closest or '-'}, {counted(s.contact_episodes, 'contact episode')}"
        f" ({s.robot_initiated_contacts} robot-initiated,{pushed}"
        f" fastest closing {s.max_closing_speed_mps:.2f} m/s)"
    )
    print(
        f"  safety supervisor: {counted(s.safety_interventions, 'intervention')}, "
        f"{counted(s.protective_stops, 'protective stop')}"
    )
    which = " (updates, commands, scripts or rules refused or removed: /log says which)"
    print(f"  rejected inputs: {s.rejected_inputs}{which if s.rejected_inputs else ''}")
    for error in s.errors[:MAX_ERRORS_SHOWN]:
        print(f"  ERROR at {error}")
    if len(s.errors) > MAX_ERRORS_SHOWN:
        print(f"  ... {len(s.errors) - MAX_ERRORS_SHOWN} more errors on /log")
    for verdict in result.verdicts:
        mark = "PASS" if verdict.ok else "FAIL"
        print(f"  {mark} {verdict.name}: {verdict.detail}")
    if live:
        print("expectations: not applicable to a live session")
        return
    passed = sum(v.ok for v in result.verdicts)
    print(f"{passed} passed, {len(result.verdicts) - passed} failed")
