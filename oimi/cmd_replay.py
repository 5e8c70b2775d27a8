"""Replay a recording and compare: redrive its pipeline (open loop) or rerun its scenario.

Exit 0 when every message matches (with the count compared per topic), 1 at the
first divergence (topic, tick, field, both values, the messages before it),
2 when the recording cannot be read or rebuilt (another format version, damage).
A rosbag2 folder is not compared: the --scenario's pipeline is driven over its map
updates and joystick (docs/ros2.md) and recorded, and a summary printed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import msgspec

from oimi import jsonout
from oimi.cmd_run import print_result
from oimi.extension_args import extensions_of
from oimi.live_options import add_foxglove_argument
from oimi.replay.compare import format_report
from oimi.replay.redrive import redrive
from oimi.replay.rerun import rerun
from oimi.ros2.network import missing_extra

MODES = {"redrive": redrive, "rerun": rerun}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "recording", type=Path, help="session recording (.mcap), or a rosbag2 folder"
    )
    parser.add_argument(
        "--mode",
        choices=tuple(MODES),
        default="redrive",
        help="redrive: recorded inputs -> pipeline (default); rerun: the scenario again",
    )
    add_foxglove_argument(parser)
    parser.add_argument(
        "--speed",
        type=float,
        default=1.0,
        help="with --foxglove: stream at this multiple of the recorded pace (0: at once)",
    )
    rosbag = parser.add_argument_group("a rosbag2 folder (docs/ros2.md)")
    rosbag.add_argument("--scenario", type=Path, help="the scenario whose pipeline is driven")
    rosbag.add_argument("-o", "--output", type=Path, help="record the drive (default: out/)")
    rosbag.add_argument("--seed", type=int, help="override the scenario's seed")
    jsonout.add_json_argument(parser)


def run(args: argparse.Namespace) -> int:
    if args.foxglove is not None and args.recording.is_dir():
        print("oimi replay: --foxglove streams an MCAP recording, not a rosbag2", file=sys.stderr)
        return 2
    if not args.speed >= 0:  # NaN too
        print("oimi replay: --speed must be 0 or more", file=sys.stderr)
        return 2
    if args.recording.is_dir():
        return _drive_rosbag(args)
    if args.scenario is not None or args.output is not None or args.seed is not None:
        print("oimi replay: --scenario, -o and --seed are for a rosbag2 folder", file=sys.stderr)
        return 2
    if extensions_of(args):
        print(
            "oimi replay: a recording replays with the extensions attached to it;"
            " --extension is for a rosbag2 folder's --scenario",
            file=sys.stderr,
        )
        return 2
    comparison = MODES[args.mode](args.recording)
    print(format_report(comparison))
    if args.foxglove is not None:
        _serve_to_foxglove(args.recording, args.foxglove, speed=args.speed)
    jsonout.emit(
        args, {"command": "replay", "ok": comparison.ok, **msgspec.to_builtins(comparison)}
    )
    return 0 if comparison.ok else 1


def _serve_to_foxglove(recording: Path, port: int, *, speed: float) -> None:
    """Stream the recording to a Foxglove client at its recorded pace, once one connects."""
    from oimi.recorder.foxglove_live import FoxgloveServer, serve_recording

    server = FoxgloveServer(port=port)
    try:
        print(f"foxglove: {server.url}  waiting for a client; Ctrl-C to stop", flush=True)
        sent = serve_recording(recording, server, speed=speed, wait_for_client=lambda: True)
        print(f"foxglove: {sent} messages streamed", flush=True)
    finally:
        server.close()


def _drive_rosbag(args: argparse.Namespace) -> int:
    if why := missing_extra():
        print(f"oimi replay: {why}", file=sys.stderr)
        return 2
    if args.mode != "redrive":
        print(
            "oimi replay: a rosbag2 is driven, not re-run: --mode does not apply", file=sys.stderr
        )
        return 2
    if args.scenario is None:
        print(
            f"oimi replay: {args.recording} is a rosbag2 folder, which carries no scenario:"
            " give --scenario SCENARIO.toml",
            file=sys.stderr,
        )
        return 2
    from oimi.ros2.bag import replay_rosbag
    from oimi.scenarios.loader import load_scenario

    output = args.output or Path("out") / f"{args.recording.name}-replay.mcap"
    result, ticks, notes = replay_rosbag(
        args.recording,
        load_scenario(args.scenario, extensions=extensions_of(args)),
        output=output,
        seed=args.seed,
    )
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    print(f"rosbag2 {args.recording}: {ticks} ticks driven")
    print_result(result)
    print(f"recording: {output}")
    jsonout.emit(
        args,
        {
            "command": "replay",
            "ok": True,
            "mode": "rosbag2",
            "recording": str(args.recording),
            "ticks": ticks,
            "notes": list(notes),
            **jsonout.result_summary(result),
            "output": str(output),
        },
    )
    return 0
