"""Replaying a recording (``oimi replay``): compare it with its pipeline redriven or its
scenario rerun, optionally streamed to Foxglove; or drive a scenario's pipeline over a
rosbag2 folder's inputs (``oimi.ros2.bag``, docs/ros2.md)."""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

from oimi.replay.compare import Comparison, format_report
from oimi.replay.redrive import redrive
from oimi.replay.rerun import rerun
from oimi.scenarios.session.runner import RunResult

MODES = {"redrive": redrive, "rerun": rerun}


def replay(recording: Path, *, mode: str, foxglove: int | None, speed: float) -> Comparison:
    """Compare ``recording`` with its replay in ``mode`` and print the report; then, with a
    ``foxglove`` port, stream it to a Foxglove client at ``speed`` times its pace."""
    comparison = MODES[mode](recording)
    print(format_report(comparison))
    if foxglove is not None:
        serve_to_foxglove(recording, foxglove, speed=speed)
    return comparison


def serve_to_foxglove(recording: Path, port: int, *, speed: float) -> None:
    """Stream the recording to a Foxglove client at its recorded pace, once one connects."""
    from oimi.recorder.foxglove_live import FoxgloveServer, serve_recording

    server = FoxgloveServer(port=port)
    try:
        print(f"foxglove: {server.url}  waiting for a client; Ctrl-C to stop", flush=True)
        sent = serve_recording(recording, server, speed=speed, wait_for_client=lambda: True)
        print(f"foxglove: {sent} messages streamed", flush=True)
    finally:
        server.close()


class Driven(NamedTuple):
    """A rosbag2 folder driven through a scenario's pipeline."""

    result: RunResult
    ticks: int
    notes: list[str]
    """The bag's inputs that were refused, and why."""
    output: Path


def drive_rosbag(
    bag: Path,
    scenario: Path,
    *,
    output: Path | None = None,
    seed: int | None = None,
    extensions: tuple[str, ...] = (),
) -> Driven:
    """Drive ``scenario``'s pipeline over the bag's map updates, joystick and commands,
    recorded to ``output`` (default ``out/BAG-replay.mcap``). Needs the ``ros2`` extra."""
    from oimi.ros2.bag import replay_rosbag
    from oimi.scenarios.loader import load_scenario

    output = output or Path("out") / f"{bag.name}-replay.mcap"
    result, ticks, notes = replay_rosbag(
        bag, load_scenario(scenario, extensions=extensions), output=output, seed=seed
    )
    return Driven(result, ticks, list(notes), output)
