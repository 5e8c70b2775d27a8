"""A recording's expectations checked again: the verdicts ``oimi run`` printed, which the
recording does not hold, from its attached scenario and its messages."""

from __future__ import annotations

from pathlib import Path

from oimi.pipeline.errors import LocatedError
from oimi.recorder.reader import open_recording
from oimi.replay.rebuild import rebuilt_pipeline
from oimi.scenarios.session.expectations import Tracker


def recorded_verdicts(path: Path) -> list[tuple[str, bool, str]] | None:
    """``(name, ok, detail)`` of each expectation of the recording's attached scenario,
    checked against its messages (streamed); None when it has no loadable scenario."""
    recording = open_recording(path)
    try:
        with rebuilt_pipeline(recording) as built:
            tracker = Tracker(built.scenario)
    except LocatedError:
        return None
    for message in recording.iter_messages(Tracker.TOPICS):
        tracker.record(message.topic, message.time_ns, message.decoded())
    return [(v.name, v.ok, v.detail) for v in tracker.verdicts()]
