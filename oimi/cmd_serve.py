"""Serve a live session: the scenario paced to the wall clock, driven by an operator.

The App Interface listens on TCP (newline-delimited JSON) and the web console on
HTTP, both on 127.0.0.1 unless --host says otherwise (then --token is required; see
docs/security.md). Every operator command and joystick state is recorded as the
input of the tick it entered, so the recording replays exactly (oimi replay --mode
redrive). The ports are bound and the outputs checked before the recording opens;
it is written as NAME.partial.mcap and renamed when the session ends (an existing
file is refused unless --overwrite). The session runs until Ctrl-C (or SIGTERM), or
for --duration-s seconds; the scenario's own duration is ignored.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from oimi.arg_types import add_world_every_argument
from oimi.cmd_check import add_outside_paths_argument
from oimi.cmd_run import print_result
from oimi.live.app import Served, live_session, serve
from oimi.live_options import add_foxglove_argument, add_session_arguments, print_session


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", type=Path, help="scenario file (.toml): the room and people")
    parser.add_argument(
        "-o", "--output", type=Path, help="MCAP file (default: out/NAME-DATE-TIME.mcap)"
    )
    parser.add_argument("--rrd", type=Path, help="also write a Rerun recording here")
    parser.add_argument(
        "--overwrite", action="store_true", help="replace existing output files (default: refuse)"
    )
    parser.add_argument("--seed", type=int, help="override the scenario's seed")
    parser.add_argument(
        "--host", default="127.0.0.1", help="address to listen on (not loopback: needs --token)"
    )
    parser.add_argument(
        "--port", type=int, default=7070, help="App Interface TCP port (0: any free port)"
    )
    parser.add_argument(
        "--http-port", type=int, default=8080, help="web console port (0: any free port)"
    )
    parser.add_argument("--no-tcp", action="store_true", help="no TCP App Interface")
    parser.add_argument("--no-console", action="store_true", help="no web console (TCP only)")
    parser.add_argument("--token", help="shared token clients must send first (auth)")
    parser.add_argument(
        "--allow-origin",
        action="append",
        default=[],
        metavar="ORIGIN",
        help="also accept the console's WebSocket from this web origin "
        "(https://tablet.example:8443); repeatable",
    )
    parser.add_argument(
        "--duration-s", type=float, help="stop after this much session time (default: Ctrl-C)"
    )
    add_world_every_argument(parser)
    add_outside_paths_argument(parser)
    add_session_arguments(parser)
    add_foxglove_argument(parser)


def run(args: argparse.Namespace) -> int:
    served = serve(args, command="oimi serve", open_session=live_session(args.seed))
    print_served(served)
    return 0


def print_served(served: Served) -> None:
    """The end-of-session report of ``oimi serve`` and ``oimi bridge``."""
    print(f"stopped after {served.ticks} ticks ({served.seconds:.1f} s)")
    print_session(served.info)
    print_result(served.result, live=True)
    print(f"recording: {served.output}", flush=True)
