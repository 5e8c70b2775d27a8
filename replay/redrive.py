"""Redrive: the recorded inputs fed to a rebuilt pipeline, its outputs compared (open loop).

No world is simulated: the pipeline is ticked from tick 0 to the recording's last tick
(that of its last world state, the last message: read from the summary when the file has
one, so the world's states are not read) with the sensor updates, operator commands and
joystick input recorded at each tick, and every message it emits (inputs echoed, map, rule
decisions and chain, progress, actuator commands, operator state, log) must equal the
recorded one, byte for byte.
"""

from __future__ import annotations

import os
from typing import Final

from oimi.pipeline.events import INPUT_TOPICS, JoystickInput, OperatorCommands, SensorUpdates, Topic
from oimi.pipeline.sink import NS_PER_MS
from oimi.recorder.reader import Recording, open_recording
from oimi.replay.compare import Comparator, Comparison, Watch, compare_ticks
from oimi.replay.rebuild import check_replayable, rebuild_notes, rebuilt_pipeline

REDRIVE_TOPICS: Final = tuple(t for t in Topic if t is not Topic.WORLD_STATE)
"""What the pipeline emits (every topic but the world's state)."""


def redrive(path: str | os.PathLike[str], *, watch: Watch | None = None) -> Comparison:
    """Redrive a recording (``RecordingError`` when it cannot be read or rebuilt);
    ``watch`` hears the progress (``compare_ticks``)."""
    return redrive_recording(open_recording(path), watch=watch)


def redrive_recording(recording: Recording, *, watch: Watch | None = None) -> Comparison:
    """Redrive an opened recording."""
    check_replayable(recording)
    with rebuilt_pipeline(recording) as built:
        notes = rebuild_notes(recording, built)
        pipeline = built.pipeline
        last_tick = _last_tick(recording, pipeline.config.tick_ms)
        comparator = Comparator(recording, compared=REDRIVE_TOPICS, last_tick=last_tick)
        built.sink.add(comparator)
        assert set(INPUT_TOPICS) <= set(REDRIVE_TOPICS)

        def step(tick: int) -> None:
            updates = comparator.inputs_at(Topic.SENSOR_UPDATES, tick)
            commands = comparator.inputs_at(Topic.OPERATOR_COMMANDS, tick)
            joystick = comparator.inputs_at(Topic.JOYSTICK, tick)
            if not (updates or commands or joystick):  # most ticks: no input
                pipeline.tick(tick=tick)
                return
            pipeline.tick(
                tick=tick,
                updates=[u for e in updates if isinstance(e, SensorUpdates) for u in e.updates],
                commands=[
                    c for e in commands if isinstance(e, OperatorCommands) for c in e.commands
                ],
                joystick=next((e for e in joystick if isinstance(e, JoystickInput)), None),
            )

        total = None if last_tick is None else last_tick + 1
        return compare_ticks(
            comparator, step, mode="redrive", notes=notes, watch=watch, total=total
        )


def _last_tick(recording: Recording, tick_ms: int) -> int | None:
    """The session's last tick from the summary: the tick of the last message, which is
    the session's last world state (None: no summary, or no world state to end on)."""
    if recording.end_ns is None or not recording.summary.get(Topic.WORLD_STATE.value):
        return None
    return recording.end_ns // (tick_ms * NS_PER_MS)
