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
import asyncio
import contextlib
import datetime
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Final

from oimi.cmd_check import add_outside_paths_argument
from oimi.cmd_run import print_result
from oimi.extension_args import extensions_of
from oimi.live.server import Addresses, LiveServer, ServeConfig, listen
from oimi.live.session import LiveSession
from oimi.live_options import (
    add_foxglove_argument,
    add_session_arguments,
    foxglove_sinks,
    print_session,
    session_info,
)
from oimi.scenarios.loader import LoadedScenario, load_scenario
from oimi.scenarios.session.recording import check_outputs, dated_path, recorded

LIVE_CHUNK_BYTES: Final = 128 * 1024
"""A live session's MCAP chunks (uncompressed): a killed session loses at most the open
chunk, a few seconds of session rather than the default 1 MiB's minute or more."""


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
    add_outside_paths_argument(parser)
    add_session_arguments(parser)
    add_foxglove_argument(parser)


def run(args: argparse.Namespace) -> int:
    @contextlib.contextmanager
    def live(loaded: LoadedScenario) -> Iterator[LiveSession]:
        yield LiveSession(loaded, seed=args.seed)

    return serve(args, command="oimi serve", open_session=live)


def serve(
    args: argparse.Namespace,
    *,
    command: str,
    open_session: Callable[[LoadedScenario], contextlib.AbstractContextManager[LiveSession]],
    suffix: str = "",
    on_server: Callable[[LiveSession, LiveServer], None] | None = None,
) -> int:
    """Check the arguments and outputs, bind the ports, then run and record a live session.

    ``open_session`` makes the session (``oimi serve``'s, or the ROS 2 bridge's);
    ``suffix`` goes after the scenario's name in the default recording name.
    """
    if args.duration_s is not None and not args.duration_s > 0:  # NaN too
        print(f"{command}: --duration-s must be positive", file=sys.stderr)
        return 2
    if args.token is not None and not args.token:
        print(f"{command}: --token must not be empty", file=sys.stderr)
        return 2
    loaded = load_scenario(
        args.scenario, allow_outside=args.allow_outside_paths, extensions=extensions_of(args)
    )
    output = args.output or dated_path(
        Path("out"), f"{args.scenario.stem}{suffix}", ".mcap", now=datetime.datetime.now()
    )
    check_outputs((output, args.rrd), overwrite=args.overwrite)
    config = ServeConfig(
        host=args.host,
        tcp_port=None if args.no_tcp else args.port,
        http_port=None if args.no_console else args.http_port,
        token=args.token,
        allow_origins=tuple(args.allow_origin),
        duration_s=args.duration_s,
    )
    listeners = listen(config)  # ports first: a busy port opens no recording
    try:
        with open_session(loaded) as session:
            info = session_info(args, session.scenario)
            server = LiveServer(session, config, on_ready=_announce, on_note=_note, info=info)
            if on_server is not None:
                on_server(session, server)
            with recorded(
                session,
                mcap=output,
                rrd=args.rrd,
                overwrite=args.overwrite,
                chunk_size_bytes=LIVE_CHUNK_BYTES,
                info=info,
                final_info=lambda: server.info,
                sinks=foxglove_sinks(args, session),
            ):
                asyncio.run(server.run(listeners))
    finally:
        listeners.close()
    print(f"stopped after {server.ticks} ticks ({server.ticks * session.tick_ms / 1000:.1f} s)")
    print_session(server.info or info)
    print_result(session.result(), live=True)
    print(f"recording: {output}", flush=True)
    return 0


def _announce(addresses: Addresses) -> None:
    if addresses.tcp is not None:
        host, port = addresses.tcp
        print(f"app interface: tcp {host}:{port}")
    if addresses.console is not None:
        print(f"console: {addresses.console}")
    print("serving; Ctrl-C to stop", flush=True)


def _note(text: str) -> None:
    print(f"note: {text}", file=sys.stderr, flush=True)
