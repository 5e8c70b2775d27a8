"""The closed-loop replay (rerun) compares the world's state as the recording sampled it:
every second tick, the ticks of a contact and after one, and the session's last; redrive
lasts to that last state without reading the states."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path

import pytest
from oimi.pipeline.events import Topic
from oimi.recorder.reader import RecordedMessage, open_recording
from oimi.replay.compare import format_report
from oimi.replay.redrive import redrive, redrive_recording
from oimi.replay.rerun import rerun
from replay_tamper import SHORT, record, rewrite


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record(SHORT, tmp_path_factory.mktemp("world") / "short.mcap")


def test_a_fresh_recording_reruns_clean_world_state_included(recording: Path) -> None:
    comparison = rerun(recording)
    assert comparison.ok, format_report(comparison)
    # 300 ticks: the states of every second tick, of the ticks of a contact and after one,
    # and of the last, 299
    world = [m.tick for m in open_recording(recording).iter_messages([Topic.WORLD_STATE])]
    assert comparison.compared[Topic.WORLD_STATE.value] == len(world) == 249
    assert world[-1] == 299 and set(range(0, 300, 2)) <= set(world)
    assert sum(comparison.compared.values()) == sum(
        n for t, n in open_recording(recording).summary.items() if not t.startswith("/foxglove")
    )


def test_rerun_compares_the_last_world_state_the_recording_wrote_at_its_close(
    recording: Path, tmp_path: Path
) -> None:
    """Tick 299 is not a second tick: its state is kept only as the session's last."""
    states = sum(1 for _ in open_recording(recording).iter_messages([Topic.WORLD_STATE]))
    tampered = tmp_path / "last.mcap"
    rewrite(
        recording,
        tampered,
        message=lambda topic, index, data: (
            data.replace(b'"x_m":', b'"x_m":1', 1)
            if topic == Topic.WORLD_STATE and index == states - 1
            else data
        ),
    )
    comparison = rerun(tampered)
    assert comparison.divergence is not None
    assert (comparison.divergence.topic, comparison.divergence.tick) == ("/world/state", 299)
    assert comparison.divergence.path == "$.robot.x_m"
    assert redrive(tampered).ticks == 300, "redrive, which compares no state, runs to the last"


@pytest.mark.parametrize("summary", [True, False])
def test_redrive_lasts_to_the_last_world_state_reading_them_only_without_a_summary(
    recording: Path, summary: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The session ends with its last world state (the recording's last message): the
    summary says when, so the world's states (half of the messages) are not read; without
    a summary they are, for their ticks."""
    opened = open_recording(recording)
    assert opened.end_ns == 299 * 20_000_000
    last_map = max(m.tick for m in opened.iter_messages([Topic.MAP]))
    assert last_map < 299, "the session lasts past its last /map message"
    if not summary:
        opened.end_ns = None
    read: list[Topic] = []
    iter_messages = type(opened).iter_messages

    def reading(self: object, topics: Iterable[Topic]) -> Iterator[RecordedMessage]:
        topics = list(topics)
        read.extend(topics)
        return iter_messages(self, topics)

    monkeypatch.setattr(type(opened), "iter_messages", reading)
    comparison = redrive_recording(opened)
    assert comparison.ok and comparison.ticks == 300
    assert (Topic.WORLD_STATE in read) is not summary
