"""Export a session recording for other tools: --ros2 writes a rosbag2 folder.

The rosbag2 has MCAP storage with zstd chunks, ros2msg definitions and CDR messages:
standard types (/cmd_vel Twist, /odom Odometry, /joy Joy, /oimi/led ColorRGBA,
/oimi/audio String) and oimi_msgs (/oimi/map_updates, /oimi/script_info,
/oimi/rule_messages), readable by `ros2 bag` and `rosbags`; `oimi replay OUT/
--scenario SCENARIO.toml` drives the pipeline over it again (docs/ros2.md).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from oimi.ros2.network import missing_extra


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--ros2", action="store_true", required=True, help="write a rosbag2 (the only format)"
    )
    parser.add_argument("recording", type=Path, help="session recording (.mcap)")
    parser.add_argument("out", type=Path, help="the rosbag2 folder to create (must not exist)")


def run(args: argparse.Namespace) -> int:
    if why := missing_extra():
        print(f"oimi export: {why}", file=sys.stderr)
        return 2
    from oimi.ros2.bag import export_rosbag

    counts = export_rosbag(args.recording, args.out)
    width = max(map(len, counts))
    print(f"rosbag2: {args.out} ({sum(counts.values())} messages)")
    for topic, count in counts.items():
        print(f"  {topic:<{width}}  {count}")
    return 0
