"""Replaying a recording (``oimi replay``): compare it with its pipeline redriven or its
scenario rerun, optionally streamed to Foxglove; or drive a scenario's pipeline over a
rosbag2 folder's inputs (``oimi.ros2.bag``, docs/ros2.md)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import msgspec

from oimi.console import Progress
from oimi.recorder.errors import RecordingError
from oimi.recorder.reader import Recording, open_recording
from oimi.replay.compare import Comparison, Watch, format_report
from oimi.replay.expectations import judgeable
from oimi.replay.redrive import redrive_recording
from oimi.replay.rerun import rerun_recording
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.session.runner import RunResult

if TYPE_CHECKING:  # (the Foxglove SDK is imported only when it serves)
    from oimi.recorder.foxglove_live import FoxgloveServer


def replay(
    recording: Path, *, mode: str, foxglove: int | None, speed: float, quiet: bool = False
) -> Comparison:
    """Compare ``recording`` with its replay in ``mode`` and print the report (with a
    progress bar on stderr unless ``quiet``, when its tick rate is recorded); then, with a
    ``foxglove`` port, stream it to a Foxglove client at ``speed`` times its pace (its
    server started first: a port in use is refused before the replay, not after it)."""
    opened = open_recording(recording)
    server = None
    if foxglove is not None:
        from oimi.recorder.foxglove_live import FoxgloveServer

        messages = sum(opened.summary.values())  # a client may fall that far behind
        server = FoxgloveServer(port=foxglove, backlog=messages)
    try:
        hz = None if quiet else opened.meta.tick_hz
        progress = Progress(f"{mode} {recording.name}", 1000 // hz) if hz else None
        try:
            comparison = MODES[mode](opened, watch=progress)
        finally:
            if progress is not None:
                progress.close()
        print(format_report(comparison))
        if server is not None:
            serve_to_foxglove(recording, server, speed=speed)
    finally:
        if server is not None:
            server.close()
    return comparison


def rerun(recording: Recording, *, watch: Watch | None = None) -> Comparison:
    """``replay.rerun.rerun_recording``, refusing up front (``RecordingError``) a live
    session's recording (its operator commands and joystick came from outside the scenario,
    which a rerun plays again) and one driven over a rosbag2 (no world to simulate again)."""
    if recording.meta.live is not None:
        raise RecordingError(
            "a live session's recording: its operator commands and joystick came from"
            " outside the scenario, which --mode rerun cannot play again;"
            " replay it with --mode redrive (the default)",
            source=recording.path,
        )
    if recording.meta.from_bag:
        raise RecordingError(
            "a recording driven over a rosbag2: its inputs came from the bag, not from the"
            " scenario's world, which --mode rerun would simulate;"
            " replay it with --mode redrive (the default)",
            source=recording.path,
        )
    return rerun_recording(recording, watch=watch)


MODES = {"redrive": redrive_recording, "rerun": rerun}


def serve_to_foxglove(recording: Path, server: FoxgloveServer, *, speed: float) -> None:
    """Stream the recording to a Foxglove client of ``server`` at its recorded pace, once
    one connects, then keep serving while a client is subscribed (it may still be
    receiving), until it leaves, Ctrl-C (which ends the command as it would have ended) or
    ``DRAIN_LIMIT_S`` (the server's backlog: how many messages the client may fall behind;
    at ``--speed 0`` it falls behind by the whole file: its message count drops none)."""
    from oimi.recorder.foxglove_live import DRAIN_LIMIT_S, serve_recording

    print(f"foxglove: {server.url}  waiting for a client; Ctrl-C to stop", flush=True)
    sent = serve_recording(recording, server, speed=speed, wait_for_client=lambda: True)
    print(
        f"foxglove: {sent} messages streamed; serving until the client disconnects"
        f" (Ctrl-C to stop; at most {DRAIN_LIMIT_S / 60:.0f} min)",
        flush=True,
    )
    try:
        left = server.wait_while_subscribed()
    except KeyboardInterrupt:
        print("foxglove: stopped (Ctrl-C)", flush=True)
    else:
        if not left:
            print("foxglove: stopped with a client still connected (time limit)")


class Driven(NamedTuple):
    """A rosbag2 folder driven through a scenario's pipeline."""

    result: RunResult
    """Its verdicts are those of the expectations a bag can judge."""
    ticks: int
    notes: list[str]
    """The bag's inputs that were refused, and why."""
    output: Path
    not_judged: list[str]
    """The expectations about people (``ABOUT_PEOPLE``), by name: a bag cannot judge them."""
    warnings: tuple[ScenarioError, ...]
    """The scenario's own warnings, and what it gets wrong of a real robot's people and
    sonar ring (``oimi bridge`` refuses those): the bag's readings came from one."""


def drive_rosbag(
    bag: Path,
    scenario: Path,
    *,
    output: Path | None = None,
    seed: int | None = None,
    extensions: tuple[str, ...] = (),
    overwrite: bool = False,
) -> Driven:
    """Drive ``scenario``'s pipeline over the bag's map updates, joystick and commands,
    recorded to ``output`` (default ``out/BAG-replay.mcap``; an existing file is replaced
    only with ``overwrite``). Needs the ``ros2`` extra.
    The expectations about people are set apart, not judged: a bag has no people."""
    from oimi.ros2.bag import replay_rosbag
    from oimi.scenarios.loader import load_scenario
    from oimi.scenarios.real_robot import real_people_problems, real_robot_warnings

    output = output or Path("out") / f"{bag.name}-replay.mcap"
    loaded = load_scenario(scenario, extensions=extensions)
    result, ticks, notes = replay_rosbag(bag, loaded, output=output, seed=seed, overwrite=overwrite)
    judged, not_judged = judgeable(loaded.scenario.expect, result.verdicts)
    result = msgspec.structs.replace(result, verdicts=judged)
    warnings = (*loaded.warnings, *real_people_problems(loaded), *real_robot_warnings(loaded))
    return Driven(result, ticks, list(notes), output, not_judged, warnings)
