"""Simulate the scenario's room and robot as a ROS 2 robot (--ros2), paced to the wall clock.

The robot obeys /cmd_vel (geometry_msgs/Twist), /oimi/led (std_msgs/ColorRGBA) and
/oimi/audio (std_msgs/String), stands still when /cmd_vel falls silent for 0.5 s, and
publishes its simulated sensors on /oimi/map_updates (oimi_msgs/MapUpdate) and its
odometry on /odom (nav_msgs/Odometry). Runs until Ctrl-C or --duration-s. DDS stays
on this machine unless the --dds-* flags say otherwise (docs/ros2.md).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from oimi.ros2.network import add_network_arguments, missing_extra


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", type=Path, help="scenario file (.toml): the room and people")
    parser.add_argument(
        "--ros2", action="store_true", required=True, help="be a ROS 2 robot (the only mode)"
    )
    parser.add_argument("-o", "--output", type=Path, help="also record the world to this MCAP")
    parser.add_argument(
        "--overwrite", action="store_true", help="replace an existing output file (default: refuse)"
    )
    parser.add_argument("--seed", type=int, help="override the scenario's seed")
    parser.add_argument(
        "--duration-s", type=float, help="stop after this much simulated time (default: Ctrl-C)"
    )
    add_network_arguments(parser)


def run(args: argparse.Namespace) -> int:
    if why := missing_extra():
        print(f"oimi sim: {why}", file=sys.stderr)
        return 2
    from oimi.ros2.sim import simulate

    done = simulate(args)
    x, y, theta = done.pose
    print(
        f"stopped after {done.ticks} ticks; {done.published} map updates sent, "
        f"{done.received} cmd_vel received; "
        f"robot at ({x:.3f}, {y:.3f}) m, heading {theta:.3f} rad",
        flush=True,
    )
    return 0
