"""RerunSink writes a readable .rrd with the agreed entity tree and simulated timelines only."""

from __future__ import annotations

from pathlib import Path

import pytest
from oimi.pipeline.events import LogEntries, Topic
from oimi.recorder.errors import RecordingError
from oimi.recorder.mcap_sink import McapSink
from oimi.recorder.rerun_sink import RerunSink, mcap_to_rrd
from recorder_synthetic import SCENE, session
from rerun.chunk import RrdReader


def write_rrd(path: Path, ticks: int = 30) -> None:
    with RerunSink(path, recording_id="greeting-7", scene=SCENE) as sink:
        for topic, time_ns, event in session(ticks):
            sink.record(topic, time_ns, event)


def chunks(path: Path):
    reader = RrdReader(path)
    return reader.recordings(), list(reader.stream().to_chunks())


def entity_paths(path: Path) -> set[str]:
    return {c.entity_path for c in chunks(path)[1]}


EXPECTED_ENTITIES = {
    "/world/arena",
    "/world/door",
    "/world/obstacles/boxes",
    "/world/obstacles/discs",
    "/world/robot",
    "/world/robot/heading",
    "/world/robot/led",
    "/world/robot/name",
    "/world/grid",
    "/world/humans/child1/zones",
    "/world/humans/child1/name",
    "/world/robot/trail",
    "/world/humans/child1",
    "/world/humans/child1/trail",
    "/world/humans/therapist1",
    "/world/objects/ball",
    "/robot/led",
    "/robot/audio",
    "/robot/speed",
    "/robot/distance/child1",
    "/robot/distance/therapist1",
    "/script/block",
    "/script/events",
    "/rules/decisions",
    "/rules/chain",
    "/log",
}


def test_rrd_holds_the_world_robot_script_rules_and_log_entities(tmp_path: Path) -> None:
    path = tmp_path / "s.rrd"
    write_rrd(path)
    assert path.stat().st_size > 0
    recordings, _ = chunks(path)
    assert [(r.application_id, r.recording_id) for r in recordings] == [("oimi", "greeting-7")]
    assert entity_paths(path) >= EXPECTED_ENTITIES


def test_rrd_has_only_simulated_timelines_and_a_static_scene(tmp_path: Path) -> None:
    path = tmp_path / "t.rrd"
    write_rrd(path)
    timelines = set()
    for chunk in chunks(path)[1]:
        timelines.update(chunk.timeline_names)
        if chunk.entity_path.startswith("/world/obstacles") or chunk.entity_path == "/world/arena":
            assert chunk.is_static
    assert timelines == {"sim_time", "tick"}


def test_mcap_to_rrd_uses_the_recorded_id_scene_and_events(tmp_path: Path) -> None:
    mcap = tmp_path / "session.mcap"
    with McapSink(mcap, metadata={"oimi": {"recording_id": "greeting-7"}}, scene=SCENE) as sink:
        for topic, time_ns, event in session(30):
            sink.record(topic, time_ns, event)
    rrd = tmp_path / "session.rrd"
    mcap_to_rrd(mcap, rrd)
    recordings, _ = chunks(rrd)
    assert [r.recording_id for r in recordings] == ["greeting-7"]
    assert entity_paths(rrd) >= EXPECTED_ENTITIES


def test_rerun_close_is_idempotent_and_recording_after_close_fails(tmp_path: Path) -> None:
    sink = RerunSink(tmp_path / "c.rrd", recording_id="c", scene=None)
    sink.close()
    sink.close()
    with pytest.raises(RecordingError, match=r"record\(/log\) after close\(\)"):
        sink.record(Topic.LOG, 0, LogEntries(tick=0, time_ms=0, entries=()))


def test_world_every_n_ticks_must_be_positive(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match=r"world_every_n_ticks must be >= 1, got 0"):
        RerunSink(tmp_path / "n.rrd", recording_id="n", world_every_n_ticks=0)


def test_world_entities_are_sampled_every_n_ticks(tmp_path: Path) -> None:
    path = tmp_path / "every.rrd"
    write_rrd(path, ticks=30)
    robot = [c for c in chunks(path)[1] if c.entity_path == "/world/robot" and not c.is_static]
    rows = sum(c.num_rows for c in robot)
    assert rows == 6  # ticks 0, 5, ..., 25
