"""Redrive and rerun of recordings: clean replays, tampered files, refusals, the CLI."""

from __future__ import annotations

import itertools
from pathlib import Path

import msgspec
import pytest
from oimi.pipeline.events import Topic
from oimi.pipeline.messages import FORMAT_VERSION
from oimi.recorder.errors import RecordingError
from oimi.recorder.reader import open_recording
from oimi.replay.compare import (
    Comparator,
    Comparison,
    DivergenceKind,
    compare_ticks,
    first_difference,
    format_report,
)
from oimi.replay.redrive import REDRIVE_TOPICS, redrive
from oimi.replay.rerun import rerun
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session import runner
from oimi.scenarios.session.activities import ACTIVITIES
from oimi.scenarios.session.build import build_pipeline
from oimi.scenarios.session.runner import Session
from replay_tamper import SHORT, record, rewrite

from oimi.cli import main

OUTPUT_TOPICS = (
    Topic.MAP,
    Topic.RULE_DECISIONS,
    Topic.RULE_CHAIN,
    Topic.READER_PROGRESS,
    Topic.ACTUATOR_COMMANDS,
    Topic.OPERATOR_STATE,
    Topic.LOG,
)


def ticks_of(path: Path, topic: Topic) -> list[int]:
    return [m.tick for m in open_recording(path).iter_messages(topics=[topic])]


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record(SHORT, tmp_path_factory.mktemp("replay") / "short.mcap")


def test_a_fresh_recording_redrives_clean_with_every_output_topic_compared(
    recording: Path,
) -> None:
    comparison = redrive(recording)
    assert comparison.ok, format_report(comparison)
    assert comparison.ticks == 300
    summary = open_recording(recording).summary
    for topic in REDRIVE_TOPICS:
        assert comparison.compared[topic.value] == summary[topic.value]
    for topic in (*OUTPUT_TOPICS, Topic.JOYSTICK, Topic.SENSOR_UPDATES):
        assert comparison.compared[topic.value] > 0, topic
    assert Topic.WORLD_STATE.value not in comparison.compared


def test_redrive_builds_no_world_and_a_session_the_same_pipeline(
    recording: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Redrive uses ``build_pipeline`` alone: with the simulated world unbuildable it still
    replays clean, and the pipeline it builds is configured as the session's was."""
    loaded = load_scenario(SHORT)
    session = Session(loaded)
    built = build_pipeline(loaded)
    assert msgspec.json.encode(built.config) == msgspec.json.encode(session.config)
    assert built.metadata() == session.metadata()
    assert built.attachments() == session.attachments()

    def no_world(*args: object, **kwargs: object) -> None:
        raise AssertionError("redrive built a world")

    monkeypatch.setattr(runner, "World", no_world)  # where a session builds one
    with pytest.raises(AssertionError, match="built a world"):
        Session(loaded)
    result = redrive(recording)
    assert result.ok, format_report(result)


def first_move(path: Path) -> tuple[int, int, int, float]:
    """(index of the message on /actuator/commands, its tick, the move's index, its v_x)."""
    for index, message in enumerate(
        open_recording(path).iter_messages(topics=[Topic.ACTUATOR_COMMANDS])
    ):
        for number, command in enumerate(msgspec.json.decode(message.payload_bytes)["commands"]):
            if command["channel"] == "move":
                return index, message.tick, number, command["v_x"]
    raise AssertionError("no move command recorded")


def test_a_changed_message_is_reported_with_topic_tick_field_and_both_values(
    recording: Path, tmp_path: Path
) -> None:
    index, tick, number, v_x = first_move(recording)

    def edit(topic: str, at: int, data: bytes) -> bytes:
        if topic != "/actuator/commands" or at != index:
            return data
        event = msgspec.json.decode(data)
        event["commands"][number]["v_x"] = v_x + 0.25
        return msgspec.json.encode(event)

    tampered = tmp_path / "changed.mcap"
    rewrite(recording, tampered, message=edit)
    for replay in (redrive, rerun):
        comparison = replay(tampered)
        d = comparison.divergence
        assert d is not None
        assert (d.kind, d.topic, d.tick, d.time_ms) == (
            "changed",
            "/actuator/commands",
            tick,
            tick * 20,
        )
        assert d.path == f"$.commands[{number}].v_x"
        assert (float(d.recorded), float(d.replayed)) == (v_x + 0.25, v_x)
        assert d.before and all(seen.tick <= tick for seen in d.before)
        report = format_report(comparison)
        for text in (
            f"DIVERGENCE (changed) on /actuator/commands at tick {tick} (t = {tick * 0.02:.3f} s)",
            f"field:    $.commands[{number}].v_x",
            f"recorded: {v_x + 0.25}",
            f"replayed: {v_x}",
            "before it (matched):",
        ):
            assert text in report


def test_a_changed_map_delta_is_reported_at_its_tick_and_field(
    recording: Path, tmp_path: Path
) -> None:
    """``/map`` records deltas: one that says a human is elsewhere diverges at its tick."""
    deltas = [
        (index, message.tick)
        for index, message in enumerate(open_recording(recording).iter_messages([Topic.MAP]))
        if b'"keyframe"' not in message.payload_bytes
        and "added"
        in msgspec.json.decode(message.payload_bytes).get("humans", [{}])[0].get("poses", {})
    ]
    index, tick = deltas[len(deltas) // 2]

    def edit(topic: str, at: int, data: bytes) -> bytes:
        if topic != "/map" or at != index:
            return data
        event = msgspec.json.decode(data)
        event["humans"][0]["poses"]["added"][-1]["positionrho"] += 1.0
        return msgspec.json.encode(event)

    tampered = tmp_path / "map.mcap"
    rewrite(recording, tampered, message=edit)
    d = redrive(tampered).divergence
    assert d is not None
    where = "$.humans[0].poses.added[0].positionrho"
    assert (d.kind, d.topic, d.tick, d.path) == ("changed", "/map", tick, where)
    rebuilt = open_recording(tampered).map_at(tick)
    original = open_recording(recording).map_at(tick)
    assert rebuilt is not None and original is not None and rebuilt != original


def test_the_reader_rebuilds_the_full_map_at_every_map_message(recording: Path) -> None:
    opened = open_recording(recording)
    maps = list(opened.maps())
    assert len(maps) == opened.summary[Topic.MAP.value] and maps[0].tick == 0
    last = maps[-1]
    assert opened.map_at(last.tick + 1000) == last.map
    assert opened.map_at(maps[1].tick - 1) == maps[0].map
    assert opened.map_at(-1) is None
    keyframes = [
        m.tick for m in opened.iter_messages([Topic.MAP]) if b'"keyframe"' in m.payload_bytes
    ]
    assert keyframes[0] == 0 and all(b - a >= 250 for a, b in itertools.pairwise(keyframes)), (
        "keyframes at least 5 s (250 ticks) apart"
    )
    session = Session(load_scenario(SHORT))
    session.run()
    assert last.map == session.pipeline.map, "the last map rebuilt is the loop's last map"


def test_a_removed_message_is_reported_as_produced_but_not_recorded(
    recording: Path, tmp_path: Path
) -> None:
    tampered = tmp_path / "removed.mcap"
    rewrite(
        recording,
        tampered,
        message=lambda topic, index, data: (
            None if topic == "/rules/decisions" and index == 50 else data
        ),
    )
    tick = ticks_of(recording, Topic.RULE_DECISIONS)[50]
    d = redrive(tampered).divergence
    assert d is not None
    assert (d.kind, d.topic, d.tick, d.path, d.recorded) == (
        DivergenceKind.EXTRA,
        "/rules/decisions",
        tick,
        "$",
        "<none>",
    )
    assert d.replayed.startswith(f'{{"tick":{tick},')


def test_a_recorded_message_the_replay_does_not_produce_is_reported_missing(
    recording: Path, tmp_path: Path
) -> None:
    tampered = tmp_path / "doubled.mcap"
    rewrite(
        recording,
        tampered,
        message=lambda topic, index, data: (
            (data, data) if topic == "/reader/progress" and index == 2 else data
        ),
    )
    d = redrive(tampered).divergence
    assert d is not None
    assert (d.kind, d.topic, d.path, d.replayed) == (
        DivergenceKind.MISSING,
        "/reader/progress",
        "$",
        "<none>",
    )
    assert d.recorded.startswith(f'{{"tick":{d.tick},')


def test_an_item_added_to_a_message_is_reported_at_its_index(
    recording: Path, tmp_path: Path
) -> None:
    tampered = tmp_path / "added.mcap"

    original: list[int] = []

    def double_decisions(topic: str, index: int, data: bytes) -> bytes:
        if topic == "/rules/decisions" and index == 10:
            event = msgspec.json.decode(data)
            original.append(len(event["decisions"]))
            event["decisions"] = [*event["decisions"], event["decisions"][0]]
            return msgspec.json.encode(event)
        return data

    rewrite(recording, tampered, message=double_decisions)
    d = redrive(tampered).divergence
    assert d is not None
    tick = ticks_of(recording, Topic.RULE_DECISIONS)[10]
    assert (d.kind, d.topic, d.tick, d.replayed) == (
        "changed",
        "/rules/decisions",
        tick,
        "<absent>",
    )
    assert d.path == f"$.decisions[{original[0]}]"
    assert d.recorded.startswith('{"rule":"child_too_close"')


def test_a_truncated_recording_is_refused_saying_where_it_is_damaged(
    recording: Path, tmp_path: Path
) -> None:
    data = recording.read_bytes()
    truncated = tmp_path / "truncated.mcap"
    truncated.write_bytes(data[: len(data) * 2 // 3])
    with pytest.raises(
        RecordingError,
        match=r"truncated.mcap: damaged at byte \d+ of \d+ \(the file ends .*\); recovered: \d+",
    ):
        redrive(truncated)
    assert main(["replay", str(truncated)]) == 2


def test_a_recording_of_another_format_version_is_refused_naming_both_versions(
    recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    old = tmp_path / "old.mcap"
    rewrite(
        recording,
        old,
        metadata=lambda name, data: {**data, "format_version": "0"} if name == "oimi" else data,
    )
    assert main(["replay", str(old)]) == 2
    err = capsys.readouterr().err
    assert "recorded with format version 0, but this oimi reads format versions 2, 3" in err
    assert "Traceback" not in err


def test_a_format_2_recording_is_read_with_its_maps_but_not_replayed(
    recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Format 2 wrote a /map delta's changed rows whole: the same maps, read as changes."""
    maps = [m.map for m in open_recording(recording).maps()]
    index = iter(range(len(maps)))

    def whole_rows(topic: str, at: int, data: bytes) -> bytes:
        if topic != "/map":
            return data
        event, world = msgspec.json.decode(data), maps[next(index)]
        for table in ("cameras", "sonars", "humans", "obstacles", "objects"):
            ids = [row["id"] for row in event.get(table, [])]
            rows = {row.id: row for row in getattr(world, table)}
            if ids:
                event[table] = [msgspec.to_builtins(rows[i]) for i in ids]
        return msgspec.json.encode(event)

    old = tmp_path / "format2.mcap"
    rewrite(
        recording,
        old,
        message=whole_rows,
        metadata=lambda name, data: {**data, "format_version": "2"} if name == "oimi" else data,
    )
    assert [m.map for m in open_recording(old).maps()] == maps
    assert main(["replay", str(old)]) == 2
    err = capsys.readouterr().err
    assert "recorded with format version 2: a replay compares every message" in err
    assert f"(format version {FORMAT_VERSION}); record the scenario again" in err


def test_a_recording_without_its_scenario_attachment_is_refused(
    recording: Path, tmp_path: Path
) -> None:
    bare = tmp_path / "bare.mcap"
    rewrite(
        recording,
        bare,
        metadata=lambda name, data: {**data, "file": "gone.toml"} if name == "scenario" else data,
    )
    with pytest.raises(RecordingError, match=r"scenario file 'gone.toml' is not attached"):
        redrive(bare)


def test_the_attached_scripts_win_over_the_installed_library(
    recording: Path, tmp_path: Path
) -> None:
    edited = tmp_path / "script.mcap"
    rewrite(
        recording,
        edited,
        attachment=lambda name, data: (
            data.replace(b'LD("1, 0, 0, 1, 0, 2000"', b'LD("0, 0, 1, 1, 0, 2000"', 1)
            if name == "activities/test_act.txt"
            else data
        ),
    )
    d = redrive(edited).divergence
    assert d is not None
    assert d.topic == "/map" or d.topic == "/actuator/commands"
    started = min(  # test_act starts after greeting ends (when depends on the child's pace)
        m.time_ns // 1_000_000
        for m in open_recording(recording).iter_messages([Topic.READER_PROGRESS])
        for item in m.decoded().items  # type: ignore[attr-defined]
        if item.kind == "load" and item.activity == "test_act"
    )
    assert d.time_ms >= started > 0


def test_a_recording_replays_from_its_attachments_after_the_scenario_files_are_gone(
    tmp_path: Path,
) -> None:
    folder = tmp_path / "mine"
    (folder / "activities").mkdir(parents=True)
    script = ACTIVITIES / "test_act.txt"
    (folder / "activities" / "mine.txt").write_text(
        script.read_text().replace("[test_act]", "[mine]")
    )
    (folder / "mine.toml").write_text(
        'name = "mine"\nduration_s = 2.0\n[[activities]]\nscript = "activities/mine.txt"\n'
    )
    path = record(folder / "mine.toml", tmp_path / "mine.mcap")
    assert "activities/mine.txt" in open_recording(path).attachments
    for child in (folder / "activities" / "mine.txt", folder / "mine.toml"):
        child.unlink()
    for replay in (redrive, rerun):
        comparison = replay(path)
        assert comparison.ok, format_report(comparison)
        assert comparison.compared[Topic.ACTUATOR_COMMANDS.value] > 0


def test_only_scripts_beside_the_scenario_are_attached_not_other_text_files(
    tmp_path: Path,
) -> None:
    """A therapist's notes beside the scenario must not travel inside the recording."""
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "mine.txt").write_text(
        (ACTIVITIES / "test_act.txt").read_text().replace("[test_act]", "[mine]")
    )
    (folder / "notes.txt").write_text("Session notes: the child was tired today.\n")
    (folder / "results.json").write_text('{"score": 3}\n')
    (folder / "mine.toml").write_text(
        'name = "mine"\nduration_s = 1.0\n[[activities]]\nscript = "mine.txt"\n'
    )
    attached = open_recording(record(folder / "mine.toml", tmp_path / "m.mcap")).attachments
    assert "activities/mine.txt" in attached and "activities/test_act.txt" in attached
    assert "activities/notes.txt" not in attached and "activities/results.json" not in attached


def test_the_comparator_holds_only_the_current_ticks_messages(recording: Path) -> None:
    opened = open_recording(recording)
    with_session = Session(load_scenario(SHORT))
    comparator = Comparator(opened, compared=REDRIVE_TOPICS)
    with_session.sink.add(comparator)
    held: list[int] = []

    def step(tick: int) -> None:
        held.append(comparator.buffered)
        with_session.step(tick)

    comparison = compare_ticks(comparator, step, mode="redrive")
    assert comparison.ticks == 300 and max(held) <= len(Topic)


def test_first_difference_names_the_path_of_the_first_differing_leaf() -> None:
    a = {"x": 1, "items": [{"v": 1.0}, {"v": 2.0}], "tail": "same"}
    assert first_difference(a, a) is None
    assert first_difference(a, {**a, "items": [{"v": 1.0}, {"v": 2.5}]}) == (
        "$.items[1].v",
        2.0,
        2.5,
    )
    path, old, _ = first_difference(a, {**a, "items": [{"v": 1.0}]}) or ("", None, None)
    assert (path, old) == ("$.items[1]", {"v": 2.0})
    assert first_difference({"a": 1}, {"a": 1.0}) == ("$.a", 1, 1.0)
    assert first_difference({"a": 1}, {"a": 1, "b": 2})[0] == "$.b"  # type: ignore[index]


def test_replay_cli_exits_0_with_counts_in_both_modes_and_1_at_a_divergence(
    recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["replay", str(recording)]) == 0
    out = capsys.readouterr().out
    assert "redrive replay" in out and "identical:" in out and "/rules/decisions" in out
    assert main(["replay", str(recording), "--mode", "rerun"]) == 0
    assert "/world/state        249" in capsys.readouterr().out
    tampered = tmp_path / "t.mcap"
    rewrite(
        recording,
        tampered,
        message=lambda topic, index, data: None if topic == "/map" and index == 3 else data,
    )
    assert main(["replay", str(tampered)]) == 1
    assert "DIVERGENCE (extra) on /map" in capsys.readouterr().out


def test_replay_shows_its_progress_on_stderr_unless_quiet(
    recording: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """An 8-hour session replays for minutes: a bar says how far (a line per quarter off a
    terminal, the last at 100 %); ``-q`` for none."""
    for mode in ("redrive", "rerun"):
        assert main(["replay", str(recording), "--mode", mode]) == 0
        err = capsys.readouterr().err.splitlines()
        assert err[-1].startswith(f"{mode} {recording.name} [{'#' * 30}] 100%"), err
    assert main(["replay", str(recording), "-q"]) == 0
    assert capsys.readouterr().err == ""


def test_an_identical_report_lists_the_count_per_topic() -> None:
    report = format_report(
        Comparison(mode="redrive", recording="x.mcap", ticks=3, compared={"/map": 2, "/log": 0})
    )
    assert report.splitlines() == [
        "redrive replay of x.mcap: 3 ticks",
        "identical: 2 messages compared",
        "  /map  2",
        "  /log  0",
    ]


def test_an_attached_scenario_that_does_not_load_is_refused_with_its_place(
    recording: Path, tmp_path: Path
) -> None:
    broken = tmp_path / "broken.mcap"
    rewrite(
        recording,
        broken,
        attachment=lambda name, data: (
            data.replace(b"seed = 7", b"seed = 'seven'") if name.startswith("scenario/") else data
        ),
    )
    with pytest.raises(
        RecordingError, match=r"attached scenario does not load: replay_short.toml:\d+:\d+: "
    ):
        redrive(broken)
