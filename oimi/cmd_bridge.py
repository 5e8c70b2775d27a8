"""Run the pipeline as a ROS 2 participant: a live session whose robot is reached over DDS.

Subscribes to /oimi/map_updates (oimi_msgs/MapUpdate), /joy (sensor_msgs/Joy, the
Xbox 360 pad with its safety lock) and /odom; publishes /cmd_vel, /oimi/led,
/oimi/audio, the script's progress and the rules' messages and decisions. The
operator's App Interface and console work as in `oimi serve`; every input is recorded
per tick, so the recording replays with `oimi replay --mode redrive`. DDS stays on
this machine unless the --dds-* flags say otherwise (docs/ros2.md).
"""

from __future__ import annotations

import argparse
import asyncio
import sys
from pathlib import Path

from oimi.cmd_run import print_result
from oimi.cmd_serve import _announce as announce
from oimi.cmd_serve import _note as note
from oimi.cmd_serve import add_arguments as add_serve_arguments
from oimi.live_options import foxglove_sinks, print_session, session_info
from oimi.ros2.network import add_network_arguments, missing_extra, network_from_args
from scenarios.live.server import LiveServer, ServeConfig
from scenarios.loader import load_scenario
from scenarios.recording import recorded


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_serve_arguments(parser)
    add_network_arguments(parser)


def run(args: argparse.Namespace) -> int:
    if why := missing_extra():
        print(f"oimi bridge: {why}", file=sys.stderr)
        return 2
    from oimi.ros2.bridge import BridgeSession
    from oimi.ros2.dds import Node

    loaded = load_scenario(args.scenario)
    network = network_from_args(args)
    output = args.output or Path("out") / f"{args.scenario.stem}-bridge.mcap"
    if args.duration_s is not None and args.duration_s <= 0:
        print("oimi bridge: --duration-s must be positive", file=sys.stderr)
        return 2
    config = ServeConfig(
        host=args.host,
        tcp_port=None if args.no_tcp else args.port,
        http_port=None if args.no_console else args.http_port,
        token=args.token,
        duration_s=args.duration_s,
    )
    with Node(network) as node:
        session = BridgeSession(loaded, node, seed=args.seed, on_note=note)
        server = LiveServer(session, config, on_ready=announce, on_note=note)
        session.attach(server.guard)
        info = session_info(args, session.scenario)
        sinks = foxglove_sinks(args, session)
        with recorded(session, mcap=output, rrd=args.rrd, info=info, sinks=sinks):
            try:
                asyncio.run(server.run())
            except OSError as error:
                print(f"oimi bridge: cannot listen on {args.host}: {error}", file=sys.stderr)
                return 2
            finally:
                session.stand_still()
    print(f"stopped after {server.ticks} ticks ({server.ticks * session.tick_ms / 1000:.1f} s)")
    print_session(info)
    print_result(session.result(), live=True)
    print(f"recording: {output}", flush=True)
    return 0
