"""The safety supervisor's ``/safety`` interventions as episodes, read from a synthetic
recording by topic name (and no episodes when a recording has no such topic)."""

from __future__ import annotations

import itertools
from pathlib import Path

from oimi.analysis.load import load_session
from oimi.analysis.memory import write_safety
from oimi.analysis.metrics import session_metrics
from oimi.analysis.stream import MAX_SAMPLES, Samples
from oimi.pipeline.events import BodyState, Topic, WorldState
from oimi.recorder.mcap_sink import McapSink

METADATA = {"scenario": {"name": "synthetic", "seed": "0", "tick_hz": "50"}}


def _world(tick: int) -> WorldState:
    robot = BodyState(id="robot", kind="robot", x_m=1.0, y_m=2.0, radius_m=0.3)
    child = BodyState(id="child1", kind="child", x_m=2.5, y_m=2.0, radius_m=0.2)
    return WorldState(tick=tick, time_ms=tick * 20, robot=robot, humans=(child,))


def _recording(path: Path, *, safety: bool) -> Path:
    with McapSink(path, metadata=METADATA, foxglove_every_n_ticks=0) as sink:
        for tick in range(200):
            sink.record(Topic.WORLD_STATE, tick * 20_000_000, _world(tick))
            if not safety:
                continue
            common = {"source": "script", "human": "child1", "requested": [0.5, 0.0, 0.0]}
            if tick == 50:
                write_safety(
                    sink,
                    1000,
                    phase="start",
                    zone="slow",
                    surface_distance_m=0.6,
                    allowed=[0.2, 0.0, 0.0],
                    **common,
                )
            elif tick == 60:
                write_safety(
                    sink,
                    1200,
                    phase="change",
                    zone="stop",
                    surface_distance_m=0.3,
                    allowed=[0.0, 0.0, 0.0],
                    **common,
                )
            elif tick == 80:
                write_safety(
                    sink,
                    1600,
                    phase="end",
                    zone="stop",
                    surface_distance_m=0.35,
                    allowed=[0.0, 0.0, 0.0],
                    **common,
                )
            elif tick == 150:  # a blind cap still running when the recording ends
                write_safety(
                    sink,
                    3000,
                    phase="start",
                    source="joystick",
                    zone="blind",
                    requested=[0.4, 0.0, 0.0],
                    allowed=[0.2, 0.0, 0.0],
                )
    return path


def test_interventions_are_episodes_from_start_to_end(tmp_path: Path) -> None:
    data = load_session(_recording(tmp_path / "safety.mcap", safety=True), stream=True)
    metrics = session_metrics(data)
    episodes = metrics["safety_interventions"].rows(named=True)
    assert [(e["started_ms"], e["ended_ms"]) for e in episodes] == [(1000, 1600), (3000, 3980)]
    first, second = episodes
    assert first["zones"] == "slow → stop"
    assert first["humans"] == "child1"
    assert first["changes"] == 1
    assert first["min_surface_distance_m"] == 0.3
    assert first["requested_mps"] == 0.5 and first["allowed_mps"] == 0.2
    assert (second["source"], second["zones"], second["humans"]) == ("joystick", "blind", "")
    summary = metrics.summary.row(0, named=True)
    assert summary["safety_interventions"] == 2
    assert summary["safety_intervention_s"] == 0.6 + 0.98


def test_a_recording_without_safety_has_no_interventions(tmp_path: Path) -> None:
    data = load_session(_recording(tmp_path / "plain.mcap", safety=False), stream=True)
    metrics = session_metrics(data)
    assert metrics["safety_interventions"].height == 0
    assert metrics.summary["safety_interventions"].item() == 0


def test_plot_samples_stay_bounded_however_long_the_session() -> None:
    samples = Samples()
    for tick in range(MAX_SAMPLES * 5 + 3):
        samples.update(_world(tick))
    assert MAX_SAMPLES // 2 <= len(samples.ticks) <= MAX_SAMPLES
    times = [rows[0][0] for rows in samples.ticks]
    assert len({b - a for a, b in itertools.pairwise(times)}) == 1  # evenly thinned
