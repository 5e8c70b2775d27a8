"""A recording's expectations checked again: the verdicts ``oimi run`` printed, which the
recording does not hold, from its attached scenario and its messages; and which of them a
session without people (driven over a rosbag2) can judge."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Final

from oimi.pipeline.errors import LocatedError
from oimi.recorder.reader import open_recording
from oimi.replay.rebuild import rebuilt_pipeline
from oimi.scenarios.schema import (
    ClosingSpeedAtContact,
    Expectation,
    MinDistance,
    NoRobotInitiatedContact,
)
from oimi.scenarios.session.expectations import Tracker, Verdict

ABOUT_PEOPLE: Final = (MinDistance, NoRobotInitiatedContact, ClosingSpeedAtContact)
"""Expectations about the people in the room, which a rosbag2 cannot judge: its odometry
is the robot's alone (``oimi.ros2.remote.RemoteBody``)."""
NOT_JUDGED: Final = "the bag has no people"
"""Why they are not judged."""


def judgeable(
    expect: Sequence[Expectation], verdicts: Sequence[Verdict]
) -> tuple[tuple[Verdict, ...], list[str]]:
    """The verdicts a bag can judge, and the names of those it cannot; ``verdicts`` are
    ``expect``'s, in its order (``Tracker.verdicts``)."""
    judged: list[Verdict] = []
    not_judged: list[str] = []
    for expectation, verdict in zip(expect, verdicts, strict=True):
        if isinstance(expectation, ABOUT_PEOPLE):
            not_judged.append(verdict.name)
        else:
            judged.append(verdict)
    return tuple(judged), not_judged


def recorded_verdicts(path: Path) -> list[tuple[str, bool, str]] | None:
    """``(name, ok, detail)`` of each expectation of the recording's attached scenario,
    checked against its messages (streamed); None when it has no loadable scenario, or is a
    live session's (the scenario's expectations are about its scripted run). A session
    driven over a rosbag2 has only the expectations it can judge (none about people)."""
    recording = open_recording(path)
    if recording.meta.live is not None:
        return None
    try:
        with rebuilt_pipeline(recording) as built:
            tracker = Tracker(built.scenario)
    except LocatedError:
        return None
    for message in recording.iter_messages(Tracker.TOPICS):
        tracker.record(message.topic, message.time_ns, message.decoded())
    verdicts = tuple(tracker.verdicts())
    if recording.meta.from_bag:
        verdicts, _ = judgeable(built.scenario.expect, verdicts)
    return [(v.name, v.ok, v.detail) for v in verdicts]
