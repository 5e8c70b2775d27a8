"""Replay a recording and compare: redrive its pipeline (open loop) or rerun its scenario.

Exit 0 when every message matches (with the count compared per topic), 1 at the
first divergence (topic, tick, field, both values, the messages before it),
2 when the recording cannot be read or rebuilt (another format version, damage), or is a
live session's and --mode rerun was asked (its outside inputs replay only in redrive).
A rosbag2 folder is not compared: the --scenario's pipeline is driven over its map
updates and joystick (docs/ros2.md) and recorded, and a summary printed; as with
``oimi run``, exit 0 when every expectation holds, 1 when one fails. Expectations about
people are not judged (a bag has no people). The work is ``oimi/replaying.py``'s.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import msgspec

from oimi import jsonout
from oimi.cmd_check import report_warnings
from oimi.cmd_run import print_result
from oimi.extension_args import extensions_of
from oimi.live_options import add_foxglove_argument
from oimi.replay.expectations import NOT_JUDGED
from oimi.replaying import MODES, drive_rosbag, replay
from oimi.ros2.network import missing_extra


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
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    rosbag = parser.add_argument_group("a rosbag2 folder (docs/ros2.md)")
    rosbag.add_argument("--scenario", type=Path, help="the scenario whose pipeline is driven")
    rosbag.add_argument("-o", "--output", type=Path, help="record the drive (default: out/)")
    rosbag.add_argument("--seed", type=int, help="override the scenario's seed")
    rosbag.add_argument(
        "--overwrite", action="store_true", help="replace an existing output file (default: refuse)"
    )
    jsonout.add_json_argument(parser)


def run(args: argparse.Namespace) -> int:
    if problem := _argument_problem(args):
        print(f"oimi replay: {problem}", file=sys.stderr)
        return 2
    if args.recording.is_dir():
        return _drive_rosbag(args)
    comparison = replay(
        args.recording, mode=args.mode, foxglove=args.foxglove, speed=args.speed, quiet=args.quiet
    )
    jsonout.emit(
        args, {"command": "replay", "ok": comparison.ok, **msgspec.to_builtins(comparison)}
    )
    return 0 if comparison.ok else 1


def _argument_problem(args: argparse.Namespace) -> str:
    """Why these arguments cannot replay (``""``: they can)."""
    if args.foxglove is not None and args.recording.is_dir():
        return "--foxglove streams an MCAP recording, not a rosbag2"
    if not args.speed >= 0:  # NaN too
        return "--speed must be 0 or more"
    if args.recording.is_dir():
        if not (args.recording / "metadata.yaml").is_file():
            return (
                f"{args.recording}: cannot read: a folder, but not a rosbag2 (it has no"
                " metadata.yaml); give an MCAP recording or a rosbag2 folder"
            )
        if why := missing_extra():
            return why
        if args.mode != "redrive":
            return "a rosbag2 is driven, not re-run: --mode does not apply"
        if args.scenario is None:
            return (
                f"{args.recording} is a rosbag2 folder, which carries no scenario:"
                " give --scenario SCENARIO.toml"
            )
        return ""
    if args.scenario is not None or args.output is not None or args.seed is not None:
        return "--scenario, -o and --seed are for a rosbag2 folder"
    if args.overwrite:
        return "--overwrite is for a rosbag2 folder's -o (a replay writes no file)"
    if extensions_of(args):
        return (
            "a recording replays with the extensions attached to it;"
            " --extension is for a rosbag2 folder's --scenario"
        )
    return ""


def _drive_rosbag(args: argparse.Namespace) -> int:
    driven = drive_rosbag(
        args.recording,
        args.scenario,
        output=args.output,
        seed=args.seed,
        extensions=tuple(extensions_of(args)),
        overwrite=args.overwrite,
    )
    report_warnings(driven.warnings)
    for note in driven.notes:
        print(f"note: {note}", file=sys.stderr)
    print(f"rosbag2 {args.recording}: {driven.ticks} ticks driven")
    print_result(driven.result)
    if driven.not_judged:
        print(f"not judged ({NOT_JUDGED}): {'; '.join(driven.not_judged)}")
    print(f"recording: {driven.output}")
    jsonout.emit(
        args,
        {
            "command": "replay",
            "ok": driven.result.ok,
            "mode": "rosbag2",
            "recording": str(args.recording),
            "ticks": driven.ticks,
            "notes": driven.notes,
            "warnings": [str(warning) for warning in driven.warnings],
            **jsonout.result_summary(driven.result),
            "not_judged": [{"name": name, "why": NOT_JUDGED} for name in driven.not_judged],
            "output": str(driven.output),
        },
    )
    return 0 if driven.result.ok else 1
