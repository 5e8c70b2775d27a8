"""Simulate the scenario's room and robot as a ROS 2 robot (--ros2), paced to the wall clock.

The robot obeys /cmd_vel (geometry_msgs/Twist), /oimi/led (std_msgs/ColorRGBA) and
/oimi/audio (std_msgs/String), stands still when /cmd_vel falls silent for 0.5 s, and
publishes its simulated sensors on /oimi/map_updates (oimi_msgs/MapUpdate) and its
odometry on /odom (nav_msgs/Odometry). Runs until Ctrl-C or --duration-s. DDS stays
on this machine unless the --dds-* flags say otherwise (docs/ros2.md).
"""

from __future__ import annotations

import argparse
import asyncio
import sys
from pathlib import Path

from oimi.live.app import note
from oimi.live.server import Addresses, LiveServer, ServeConfig
from oimi.ros2.network import add_network_arguments, missing_extra, network_from_args
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.recording import recorded


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", type=Path, help="scenario file (.toml): the room and people")
    parser.add_argument(
        "--ros2", action="store_true", required=True, help="be a ROS 2 robot (the only mode)"
    )
    parser.add_argument("-o", "--output", type=Path, help="also record the world to this MCAP")
    parser.add_argument("--seed", type=int, help="override the scenario's seed")
    parser.add_argument(
        "--duration-s", type=float, help="stop after this much simulated time (default: Ctrl-C)"
    )
    add_network_arguments(parser)


def run(args: argparse.Namespace) -> int:
    if why := missing_extra():
        print(f"oimi sim: {why}", file=sys.stderr)
        return 2
    from oimi.ros2.dds import Node
    from oimi.ros2.sim import SimSession

    loaded = load_scenario(args.scenario)
    network = network_from_args(args)
    if args.duration_s is not None and args.duration_s <= 0:
        print("oimi sim: --duration-s must be positive", file=sys.stderr)
        return 2
    config = ServeConfig(tcp_port=None, http_port=None, duration_s=args.duration_s)
    with Node(network) as node:
        session = SimSession(loaded, node, seed=args.seed, on_note=note)
        server = LiveServer(session, config, on_ready=_announce, on_note=note)
        with recorded(session, mcap=args.output, rrd=None):
            asyncio.run(server.run())
    x, y, theta = session.world.robot_pose()
    print(
        f"stopped after {server.ticks} ticks; {session.mind.published} map updates sent, "
        f"{session.commands_received} cmd_vel received; "
        f"robot at ({x:.3f}, {y:.3f}) m, heading {theta:.3f} rad",
        flush=True,
    )
    return 0


def _announce(_: Addresses) -> None:
    print("simulating; Ctrl-C to stop", flush=True)
