"""Run a library scenario end to end, recorded to MCAP and Rerun, and say how to watch it.

The demo owns its two files in --out (out/NAME.mcap, out/NAME.rrd) and replaces them on
purpose each time, so `make demo` can run again; the replacement is made only once the
new recording is complete (written as NAME.partial.*, then renamed).
Exit 0 when every expectation holds, 1 when one fails, 2 on bad input (an unknown
scenario name included).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Final

from oimi import api, console
from oimi.cmd_run import print_result
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.runner import library_scenarios

DEFAULT_SCENARIO: Final = "three_activity_session"
"""A lively session: a greeting, the test dance and the blink, one after the other."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--out", type=Path, default=Path("out"), help="folder for the recordings (default: out)"
    )
    parser.add_argument(
        "--scenario",
        default=DEFAULT_SCENARIO,
        help=f"a library scenario's file name without .toml (default: {DEFAULT_SCENARIO})",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def scenario_path(name: str) -> Path:
    """The library scenario called ``name`` (file stem); a ``ScenarioError`` lists the others."""
    paths = {path.stem: path for path in library_scenarios()}
    if name not in paths:
        raise ScenarioError(
            f"no library scenario {name!r}; choose one of {', '.join(paths)}",
            source="--scenario",
        )
    return paths[name]


def run(args: argparse.Namespace) -> int:
    path = scenario_path(args.scenario)
    loaded = load_scenario(path)
    out: Path = args.out
    mcap, rrd = out / f"{path.stem}.mcap", out / f"{path.stem}.rrd"
    watch = None if args.quiet else console.Progress.of
    outcome = api.run(loaded, output=mcap, rrd=rrd, overwrite=True, watch=watch)
    print(f"{path.name}: {loaded.scenario.description.strip()}")
    print_result(outcome.result)
    print(f"recording: {mcap}")
    print(f"rerun:     {rrd}")
    print(f"watch it:  oimi view {rrd}   (or open {mcap} in Foxglove)")
    return 0 if outcome.ok else 1
