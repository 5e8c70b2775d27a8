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
import sys

from oimi.cmd_serve import add_arguments as add_serve_arguments
from oimi.cmd_serve import print_served
from oimi.ros2.network import add_network_arguments, missing_extra


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_serve_arguments(parser)
    add_network_arguments(parser)


def run(args: argparse.Namespace) -> int:
    if why := missing_extra():
        print(f"oimi bridge: {why}", file=sys.stderr)
        return 2
    from oimi.ros2.bridge import serve_bridge

    print_served(serve_bridge(args))
    return 0
