"""Which world states a recording keeps (format 4): every second tick, the ticks of a
contact and the one after it, and the session's last state, written at close."""

from __future__ import annotations

from pathlib import Path

import msgspec
import pytest
from oimi.pipeline.events import Topic
from oimi.pipeline.proximity import ProximityTracker
from oimi.recorder.errors import RecordingError
from oimi.recorder.mcap_sink import McapSink
from oimi.recorder.metadata import OimiRecord
from oimi.recorder.reader import open_recording
from oimi.recorder.world_sampling import WorldSampling, recorded_sampling
from recorder_synthetic import TICK_NS, world_state

TOUCHED = (3, 4)
"""Ticks at which child1 touches the robot."""


def states(ticks: int):
    for tick in range(ticks):
        contacts = ("child1",) if tick in TOUCHED else ()
        yield msgspec.structs.replace(world_state(tick), contacts=contacts)


def test_every_second_tick_the_contacts_the_tick_after_and_the_last_are_kept() -> None:
    sampling = WorldSampling()
    kept = [s.tick for s in states(10) if sampling.keep(s.tick * TICK_NS, s)]
    assert kept == [0, 2, 3, 4, 5, 6, 8]
    held = sampling.last()
    assert held is not None and held[0] == 9 * TICK_NS and held[1].tick == 9
    assert sampling.last() is None, "once"


def test_the_sink_writes_them_in_order_and_the_last_at_close(tmp_path: Path) -> None:
    path = tmp_path / "sampled.mcap"
    with McapSink(path) as sink:
        for state in states(10):
            sink.record(Topic.WORLD_STATE, state.tick * TICK_NS, state)
    recording = open_recording(path)
    written = [(m.tick, m.time_ns) for m in recording.iter_messages([Topic.WORLD_STATE])]
    assert written == [(t, t * TICK_NS) for t in (0, 2, 3, 4, 5, 6, 8, 9)]
    assert recording.meta.oimi.world_every_n_ticks == "2" and recording.meta.oimi.world_every == 2
    assert recording.summary[Topic.WORLD_STATE] == 8


def test_an_even_last_tick_is_not_written_twice(tmp_path: Path) -> None:
    path = tmp_path / "even.mcap"
    with McapSink(path, world_every_n_ticks=3) as sink:
        for state in states(10):
            sink.record(Topic.WORLD_STATE, state.tick * TICK_NS, state)
    ticks = [m.tick for m in open_recording(path).iter_messages([Topic.WORLD_STATE])]
    assert ticks == [0, 3, 4, 5, 6, 9]


def test_a_sampling_below_one_or_unreadable_is_refused() -> None:
    with pytest.raises(RecordingError, match="world_every_n_ticks must be >= 1, got 0"):
        WorldSampling(0)
    for value in ("two", "0", "-3"):  # a recording's metadata names the file
        with pytest.raises(RecordingError) as raised:
            recorded_sampling(OimiRecord(world_every_n_ticks=value), source="s.mcap")
        assert str(raised.value) == (
            f"s.mcap: metadata: world_every_n_ticks is not a positive integer: {value!r}"
        )
    record = OimiRecord()
    assert recorded_sampling(record, source="s.mcap").every_n_ticks == 1, "before format 4"
    record = OimiRecord(world_every_n_ticks="5")
    assert recorded_sampling(record, source="s.mcap").every_n_ticks == 5


def test_time_in_each_zone_read_from_the_samples_is_the_sessions() -> None:
    """Each sample counts for the time since the one before, so a recording's zone times
    add up to the session's, as if every tick had been read."""
    every, sampled = ProximityTracker(tick_ms=20), ProximityTracker(tick_ms=20)
    sampling = WorldSampling()
    for state in states(11):
        every.update(state)
        if sampling.keep(0, state):
            sampled.update(state)
    assert sampled.zone_ms == every.zone_ms
    assert sum(every.zone_ms["child1"].values()) == 11 * 20


def test_the_sampling_reads_as_every_tick_before_format_4_and_none_when_unreadable() -> None:
    assert OimiRecord().world_every == 1
    assert OimiRecord(world_every_n_ticks="x").world_every is None
