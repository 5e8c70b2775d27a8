"""Rerun: the recorded scenario played again, world included, and the whole session compared.

The session is rebuilt from the recording (scenario, scripts, seed) and run
closed loop for as many ticks as the recording lasts; every topic, the world's
state included, must equal the recorded one, byte for byte. Inputs come from
the scenario again (its schedule), so this mode suits scenario runs; a live
session's outside inputs replay only in redrive mode.
"""

from __future__ import annotations

import os

from oimi.pipeline.events import Topic
from oimi.recorder.reader import Recording, open_recording
from oimi.replay.compare import Comparator, Comparison, Watch, compare_ticks
from oimi.replay.rebuild import check_replayable, rebuild_notes, rebuilt_session


def rerun(path: str | os.PathLike[str], *, watch: Watch | None = None) -> Comparison:
    """Rerun a recording's scenario (``RecordingError`` when it cannot be read or rebuilt);
    ``watch`` hears the progress (``compare_ticks``)."""
    return rerun_recording(open_recording(path), watch=watch)


def rerun_recording(recording: Recording, *, watch: Watch | None = None) -> Comparison:
    """Rerun an opened recording's scenario."""
    check_replayable(recording)
    with rebuilt_session(recording) as session:
        notes = rebuild_notes(recording, session)
        comparator = Comparator(recording, compared=tuple(Topic))
        session.sink.add(comparator)
        return compare_ticks(
            comparator,
            session.step,
            mode="rerun",
            notes=notes,
            watch=watch,
            total=session.scenario.ticks,
        )
