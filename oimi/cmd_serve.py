"""Serve a live session: the scenario paced to the wall clock, driven by an operator.

The App Interface listens on TCP (newline-delimited JSON) and the web console on
HTTP, both on 127.0.0.1 unless --host says otherwise. Every operator command and
joystick state is recorded as the input of the tick it entered, so the recording
replays exactly (oimi replay --mode redrive). The session runs until Ctrl-C
(or SIGTERM), or for --duration-s seconds; the scenario's own duration is ignored.
"""

from __future__ import annotations

import argparse
import asyncio
import ipaddress
import sys
from pathlib import Path

from oimi.cmd_check import add_outside_paths_argument
from oimi.cmd_run import print_result
from oimi.live_options import (
    add_foxglove_argument,
    add_session_arguments,
    foxglove_sinks,
    print_session,
    session_info,
)
from scenarios.live.server import Addresses, LiveServer, ServeConfig
from scenarios.live.session import LiveSession
from scenarios.loader import load_scenario
from scenarios.recording import recorded


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", type=Path, help="scenario file (.toml): the room and people")
    parser.add_argument("-o", "--output", type=Path, help="MCAP file (default: out/NAME.mcap)")
    parser.add_argument("--rrd", type=Path, help="also write a Rerun recording here")
    parser.add_argument("--seed", type=int, help="override the scenario's seed")
    parser.add_argument("--host", default="127.0.0.1", help="address to listen on")
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
        "--duration-s", type=float, help="stop after this much session time (default: Ctrl-C)"
    )
    add_outside_paths_argument(parser)
    add_session_arguments(parser)
    add_foxglove_argument(parser)


def run(args: argparse.Namespace) -> int:
    loaded = load_scenario(args.scenario, allow_outside=args.allow_outside_paths)
    output = args.output or Path("out") / f"{args.scenario.stem}-live.mcap"
    if args.duration_s is not None and not args.duration_s > 0:  # NaN too
        print("oimi serve: --duration-s must be positive", file=sys.stderr)
        return 2
    if not _loopback(args.host) and args.token is None:
        print(
            f"warning: listening on {args.host} without --token: anyone who can reach "
            "this port can drive the robot",
            file=sys.stderr,
        )
    config = ServeConfig(
        host=args.host,
        tcp_port=None if args.no_tcp else args.port,
        http_port=None if args.no_console else args.http_port,
        token=args.token,
        duration_s=args.duration_s,
    )
    session = LiveSession(loaded, seed=args.seed)
    info = session_info(args, session.scenario)
    server = LiveServer(session, config, on_ready=_announce, on_note=_note)
    sinks = foxglove_sinks(args, session)
    with recorded(session, mcap=output, rrd=args.rrd, info=info, sinks=sinks):
        try:
            asyncio.run(server.run())
        except OSError as error:
            print(f"oimi serve: cannot listen on {args.host}: {error}", file=sys.stderr)
            return 2
    print(f"stopped after {server.ticks} ticks ({server.ticks * session.tick_ms / 1000:.1f} s)")
    print_session(info)
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


def _loopback(host: str) -> bool:
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False
