"""McapSink writes Foxglove-readable, byte-stable MCAP; the reader gets it back, even damaged."""

from __future__ import annotations

import io
import json
from collections import Counter, defaultdict
from pathlib import Path

import jsonschema
import msgspec
import pytest
from mcap.exceptions import EndOfFile
from mcap.reader import make_reader
from mcap.records import Channel
from mcap.stream_reader import StreamReader
from mcap.writer import Writer
from oimi.pipeline.events import TOPIC_TYPES, Level, LogEntries, LogEntry, Topic, WorldState
from oimi.pipeline.messages import FORMAT_VERSION
from oimi.recorder import foxglove
from oimi.recorder.errors import RecordingError
from oimi.recorder.mcap_sink import McapSink
from oimi.recorder.reader import open_recording
from oimi.recorder.scene import SceneGeometry
from oimi.recorder.topics import SCENE_ATTACHMENT, FoxgloveTopic
from recorder_foxglove_paths import FOXGLOVE_SCHEMAS
from recorder_synthetic import SCENE, TICK_NS, session, world_state

METADATA = {"scenario": {"name": "greeting", "seed": "7"}, "oimi": {"recording_id": "greeting-7"}}
ATTACHMENTS = [("greeting.toml", b'name = "greeting"\n'), ("notes.txt", b"hello")]


def write(target, events=None, **options) -> None:
    """The synthetic session (or ``events``) through a sink keeping every world state
    unless told otherwise (the sampling has its own tests)."""
    options.setdefault("world_every_n_ticks", 1)
    options.setdefault("metadata", METADATA)
    options.setdefault("attachments", ATTACHMENTS)
    options.setdefault("scene", SCENE)
    with McapSink(target, **options) as sink:
        for topic, time_ns, event in events if events is not None else session():
            sink.record(topic, time_ns, event)


@pytest.fixture
def recorded(tmp_path: Path) -> Path:
    path = tmp_path / "session.mcap"
    write(path)
    return path


def raw_messages(path: Path):
    with open(path, "rb") as f:
        reader = make_reader(f)
        return [(schema, channel, message) for schema, channel, message in reader.iter_messages()]


def test_every_topic_is_recorded_and_decodes_into_its_struct(recorded: Path) -> None:
    expected = session()
    got = list(open_recording(recorded).iter_messages())
    assert [(m.topic, m.time_ns) for m in got] == [(t, ns) for t, ns, _ in expected]
    assert [m.decoded() for m in got] == [e for _, _, e in expected]
    assert {m.topic for m in got} == set(Topic)
    assert all(type(m.decoded()) is TOPIC_TYPES[m.topic] for m in got)
    assert [m.tick for m in got] == [e.tick for _, _, e in expected]


def test_mcap_library_reader_sees_every_topic_with_json_schemas(recorded: Path) -> None:
    topics = {channel.topic: (schema, channel) for schema, channel, _ in raw_messages(recorded)}
    assert set(topics) == {*Topic, *FoxgloveTopic}
    for topic in Topic:
        schema, channel = topics[topic]
        assert (schema.encoding, channel.message_encoding) == ("jsonschema", "json")
        assert schema.name == f"oimi.{TOPIC_TYPES[topic].__name__}"
    for topic in FoxgloveTopic:
        schema, channel = topics[topic]
        title = json.loads(schema.data)["title"]
        assert schema.name == title and title.startswith("foxglove.")
        assert channel.message_encoding == "json"


def test_every_message_validates_against_its_channel_schema(recorded: Path) -> None:
    validators = {}
    for schema, channel, message in raw_messages(recorded):
        if channel.topic not in validators:
            schema_doc = json.loads(schema.data)
            jsonschema.Draft202012Validator.check_schema(schema_doc)
            validators[channel.topic] = jsonschema.Draft202012Validator(schema_doc)
        validators[channel.topic].validate(json.loads(message.data))
    assert set(validators) == {*Topic, *FoxgloveTopic}


def test_foxglove_channels_carry_foxgloves_schema_files_written_compactly(recorded: Path) -> None:
    """The same JSON as the shipped files, keys in the same order, without their spaces."""
    seen = {}
    for schema, channel, _ in raw_messages(recorded):
        seen[channel.topic] = schema.data
    for topic, name in {
        FoxgloveTopic.SCENE: "SceneUpdate.json",
        FoxgloveTopic.ARENA: "SceneUpdate.json",
        FoxgloveTopic.TF: "FrameTransforms.json",
        FoxgloveTopic.LOG: "Log.json",
    }.items():
        shipped = (FOXGLOVE_SCHEMAS / name).read_text()
        assert seen[topic].decode() == json.dumps(json.loads(shipped), separators=(",", ":"))
        assert len(seen[topic]) < len(shipped)


def test_foxglove_messages_validate_against_the_shared_schema_files(recorded: Path) -> None:
    files = {
        FoxgloveTopic.SCENE: "SceneUpdate.json",
        FoxgloveTopic.ARENA: "SceneUpdate.json",
        FoxgloveTopic.TF: "FrameTransforms.json",
        FoxgloveTopic.LOG: "Log.json",
    }
    validators = {
        t: jsonschema.Draft202012Validator(json.loads((FOXGLOVE_SCHEMAS / f).read_text()))
        for t, f in files.items()
    }
    count = 0
    for _, channel, message in raw_messages(recorded):
        if channel.topic in validators:
            validators[channel.topic].validate(json.loads(message.data))
            count += 1
    assert count > 0


def test_log_and_publish_times_are_the_simulated_times(recorded: Path) -> None:
    for _, channel, message in raw_messages(recorded):
        assert message.log_time == message.publish_time
        if channel.topic in set(Topic):
            assert message.log_time == json.loads(message.data)["tick"] * TICK_NS


def test_records_leave_the_sequence_unused_and_the_reader_counts_each_channel(
    recorded: Path,
) -> None:
    """Sequence 0 in every record (MCAP's "not used": a counter cost 3 % of a recording);
    a message read is numbered by its place on its channel, from 0."""
    assert {message.sequence for _, _, message in raw_messages(recorded)} == {0}
    per_topic = defaultdict(list)
    for message in open_recording(recorded).iter_messages():
        per_topic[message.topic].append(message.sequence)
    assert per_topic and all(seq == list(range(len(seq))) for seq in per_topic.values())


def test_metadata_and_attachments_round_trip(recorded: Path) -> None:
    recording = open_recording(recorded)
    assert recording.metadata == {
        "oimi": {
            "format_version": str(FORMAT_VERSION),
            "recording_id": "greeting-7",
            "world_every_n_ticks": "1",
        },
        "scenario": {"name": "greeting", "seed": "7"},
    }
    assert list(recording.metadata) == ["oimi", "scenario"]
    assert recording.format_version == FORMAT_VERSION
    assert {k: v for k, v in recording.attachments.items() if k != SCENE_ATTACHMENT} == dict(
        ATTACHMENTS
    )
    scene = msgspec.json.decode(recording.attachments[SCENE_ATTACHMENT], type=SceneGeometry)
    assert scene == SCENE
    with open(recorded, "rb") as f:
        attachments = list(make_reader(f).iter_attachments())
    assert {(a.name, a.media_type, a.log_time, a.create_time) for a in attachments} >= {
        ("greeting.toml", "application/toml", 0, 0),
        ("notes.txt", "text/plain", 0, 0),
    }


def test_summary_counts_messages_per_topic(recorded: Path) -> None:
    summary = open_recording(recorded).summary
    assert all(summary[t] == 6 for t in Topic)
    assert summary[FoxgloveTopic.LOG] == 12


def test_header_profile_is_empty_and_library_names_versions_only(recorded: Path) -> None:
    with open(recorded, "rb") as f:
        header = make_reader(f).get_header()
    assert header.profile == ""
    assert header.library.startswith(f"oimi format {FORMAT_VERSION}, mcap-python ")


def test_two_writes_of_the_same_events_are_byte_identical(tmp_path: Path) -> None:
    first, second = io.BytesIO(), io.BytesIO()
    write(first)
    write(second)
    write(tmp_path / "third.mcap")
    assert first.getvalue() == second.getvalue() == (tmp_path / "third.mcap").read_bytes()


def test_iter_messages_filters_topics_and_rejects_unknown_ones(recorded: Path) -> None:
    recording = open_recording(recorded)
    got = list(recording.iter_messages([Topic.LOG, "/joystick"]))
    assert Counter(m.topic for m in got) == {Topic.LOG: 6, Topic.JOYSTICK: 6}
    with pytest.raises(RecordingError, match=r"unknown topic '/nope'; known topics: /sensors"):
        list(recording.iter_messages(["/nope"]))


def test_a_payload_that_is_not_its_topics_names_the_file(recorded: Path) -> None:
    """A damaged channel record can file a message under another topic (found by fuzzing:
    ``oimi analyse`` then said ``<input>:`` instead of the file)."""
    message = next(open_recording(recorded).iter_messages([Topic.JOYSTICK]))
    misfiled = msgspec.structs.replace(message, topic=Topic.LOG)
    with pytest.raises(RecordingError) as raised:
        misfiled.decoded()
    assert str(raised.value).startswith(f"{recorded}: /log message 0 (tick 0): Object ")


def test_truncated_file_recovers_the_complete_chunks_with_a_report(tmp_path: Path) -> None:
    whole = tmp_path / "whole.mcap"
    write(whole, session(40), chunk_size_bytes=4096)
    with open(whole, "rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    assert len(chunks) > 3
    middle = chunks[len(chunks) // 2]
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole.read_bytes()[: middle.chunk_start_offset + middle.chunk_length // 2])
    recording = open_recording(cut)
    assert recording.recovery is not None
    assert str(recording.recovery).startswith(
        f"damaged at byte {recording.recovery.stopped_at_byte} of {len(cut.read_bytes())}"
        " (the file ends inside a chunk record, which declares "
    )
    assert str(recording.recovery).endswith(
        f"; recovered: {recording.recovery.messages} messages before it"
    )
    got = [m.decoded() for m in recording.iter_messages()]
    expected = [e for _, _, e in session(40)]
    assert 0 < len(got) < len(expected)
    assert got == expected[: len(got)]
    assert recording.metadata["scenario"] == METADATA["scenario"]


def test_an_unfinished_file_already_holds_header_schemas_channels_and_metadata(
    tmp_path: Path,
) -> None:
    path = tmp_path / "killed.mcap"
    sink = McapSink(path, metadata=METADATA, attachments=ATTACHMENTS, scene=SCENE)
    sink.record(Topic.WORLD_STATE, 0, world_state(0))  # still in the open chunk
    with open(path, "rb") as f:
        channels = _channels_before_error(f)
    assert channels == [*Topic, *FoxgloveTopic]
    recording = open_recording(path)
    assert recording.metadata["scenario"] == METADATA["scenario"]
    assert recording.recovery is not None
    assert "the file ends without its summary and footer" in recording.recovery.reason
    assert list(recording.iter_messages()) == []
    sink.close()
    assert [m.topic for m in open_recording(path).iter_messages()] == [Topic.WORLD_STATE]


def _channels_before_error(f) -> list[str]:
    topics = []
    try:
        for record in StreamReader(f).records:
            if isinstance(record, Channel):
                topics.append(record.topic)
    except EndOfFile:  # the unfinished file ends without a footer
        pass
    return topics


def test_a_file_that_is_not_mcap_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "notes.mcap"
    path.write_text("just some text that is long enough to not be a header\n" * 3)
    with pytest.raises(RecordingError, match=r"notes\.mcap: not an MCAP file"):
        open_recording(path)


def test_an_empty_file_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "empty.mcap"
    path.write_bytes(b"")
    with pytest.raises(RecordingError, match=r"empty\.mcap: empty file"):
        open_recording(path)


def test_a_missing_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match=r"missing\.mcap: cannot read"):
        open_recording(tmp_path / "missing.mcap")


def test_a_recording_of_another_format_version_is_refused_naming_both(tmp_path: Path) -> None:
    path = tmp_path / "old.mcap"
    with open(path, "wb") as f:
        writer = Writer(f)
        writer.start()
        writer.add_metadata("oimi", {"format_version": "99"})
        writer.finish()
    with pytest.raises(
        RecordingError,
        match=r"recorded with format version 99, but this oimi reads format versions 2, 3",
    ):
        open_recording(path)


def test_an_mcap_without_oimi_metadata_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "foreign.mcap"
    with open(path, "wb") as f:
        writer = Writer(f)
        writer.start()
        writer.finish()
    with pytest.raises(RecordingError, match=r"not an oimi recording"):
        open_recording(path)


def test_close_is_idempotent_and_recording_after_close_fails() -> None:
    stream = io.BytesIO()
    sink = McapSink(stream, metadata={}, attachments=())
    sink.close()
    size = len(stream.getvalue())
    sink.close()
    assert len(stream.getvalue()) == size
    with pytest.raises(RecordingError, match=r"record\(/log\) after close\(\)"):
        sink.record(Topic.LOG, 0, LogEntries(tick=0, time_ms=0, entries=()))


def test_non_string_metadata_is_refused() -> None:
    with pytest.raises(RecordingError, match=r"metadata record 'scenario'.*'seed'"):
        McapSink(io.BytesIO(), metadata={"scenario": {"seed": 7}})  # type: ignore[dict-item]


def _scene_updates(path: Path, topic: str = FoxgloveTopic.SCENE) -> list[tuple[int, dict]]:
    return [(m.log_time, json.loads(m.data)) for _, c, m in raw_messages(path) if c.topic == topic]


def test_foxglove_draws_the_arena_once_moves_bodies_by_transforms_and_redraws_on_a_new_look(
    tmp_path: Path,
) -> None:
    path = tmp_path / "s.mcap"
    write(path, session(6), foxglove_every_n_ticks=2)
    arena = _scene_updates(path, FoxgloveTopic.ARENA)
    assert [t for t, _ in arena] == [0]  # the last message before any time: after a seek too
    assert [e["id"] for e in arena[0][1]["entities"]] == [
        "arena",
        "door",
        "obstacle/table",
        "obstacle/pillar",
    ]
    bodies = ["robot", "human/child1", "human/therapist1", "object/ball"]
    tfs = _scene_updates(path, FoxgloveTopic.TF)
    assert [t for t, _ in tfs] == [0, 2 * TICK_NS, 4 * TICK_NS]
    for tick, (_, tf) in zip((0, 2, 4), tfs, strict=True):
        assert [t["child_frame_id"] for t in tf["transforms"]] == bodies
        assert {t["parent_frame_id"] for t in tf["transforms"]} == {"world"}
        robot = tf["transforms"][0]
        assert robot["translation"] == {"x": 1.0 + 0.01 * tick, "y": 2.0, "z": 0.0}
        assert robot["rotation"] == msgspec.to_builtins(foxglove.yaw(0.1 * tick))
    # the bodies are drawn when their look changes (the robot starts playing a sound at
    # tick 2; its LEDs are off at every even tick), each in its own frame, which moves it
    updates = _scene_updates(path)
    assert [t for t, _ in updates] == [0, 2 * TICK_NS]
    for _, update in updates:
        entities = update["entities"]
        assert [(e["id"], e["frame_id"], e["frame_locked"]) for e in entities] == [
            (body, body, True) for body in bodies
        ]
        assert {e["cylinders"][0]["pose"]["position"]["x"] for e in entities[:3]} == {0.0}
    assert updates[1][1]["entities"][0]["texts"][0]["text"] == "robot: hello.wav"
    robot = updates[0][1]["entities"][0]
    body, *strips = robot["cylinders"]
    assert body["color"] == msgspec.to_builtins(foxglove.ROBOT_BODY_COLOR)
    assert [s["color"] for s in strips] == [msgspec.to_builtins(foxglove.LED_OFF_COLOR)] * 2


def test_the_robot_is_drawn_with_a_fixed_body_and_led_strips_in_the_led_colour() -> None:
    lit = msgspec.structs.replace(world_state(1), led=(0.0, 0.0, 1.0), audio="hello.wav")
    robot = foxglove.dynamic_scene(lit, TICK_NS).entities[0]
    body, low, high = robot.cylinders
    assert body.color == foxglove.ROBOT_BODY_COLOR
    assert low.color == high.color == foxglove.Color(r=0.0, g=0.0, b=1.0)
    assert low.pose.position.z < high.pose.position.z < body.size.z
    assert low.size.x > body.size.x, "the strips sit proud of the body"
    assert robot.texts[0].text == "robot: hello.wav"


def test_foxglove_scene_deletes_humans_who_left(tmp_path: Path) -> None:
    path = tmp_path / "left.mcap"
    events = [
        (Topic.WORLD_STATE, 0, world_state(0)),
        (Topic.WORLD_STATE, TICK_NS, world_state(1, humans=("child1",))),
    ]
    write(path, events, foxglove_every_n_ticks=1)
    last = _scene_updates(path)[-1][1]
    assert [d["id"] for d in last["deletions"]] == ["human/therapist1"]
    assert last["deletions"][0]["type"] == 0


def test_foxglove_log_maps_levels_and_names_the_source(tmp_path: Path) -> None:
    path = tmp_path / "log.mcap"
    entries = tuple(LogEntry(level=level, source=f"s{level}", message="m") for level in Level)
    write(path, [(Topic.LOG, 1_500_000_000, LogEntries(tick=75, time_ms=1500, entries=entries))])
    logs = [json.loads(m.data) for _, c, m in raw_messages(path) if c.topic == FoxgloveTopic.LOG]
    assert [(log["level"], log["name"]) for log in logs] == [
        (1, "s1"),
        (2, "s2"),
        (3, "s3"),
        (4, "s4"),
    ]
    assert logs[0]["timestamp"] == {"sec": 1, "nsec": 500_000_000}


def test_foxglove_views_can_be_turned_off(tmp_path: Path) -> None:
    path = tmp_path / "plain.mcap"
    write(path, session(2), foxglove_every_n_ticks=0)
    assert set(open_recording(path).summary) == set(Topic)


def test_the_packaged_foxglove_schemas_are_the_shared_ones_unchanged() -> None:
    from recorder_foxglove_paths import PACKAGED, SHARED

    if not SHARED.is_dir():
        pytest.skip("shared/ is not beside this checkout")
    for path in sorted(PACKAGED.glob("*.json")):
        assert path.read_bytes() == (SHARED / path.name).read_bytes(), path.name


def test_a_new_look_redraws_the_robot_and_only_the_bodies_that_changed() -> None:
    views = foxglove.Views(None, every_n_ticks=1)

    def scene(state: WorldState) -> foxglove.SceneUpdate:
        (update,) = [
            v for t, v in views.world(state, state.tick * TICK_NS) if t == "/foxglove/scene"
        ]
        return update

    first = scene(world_state(0))
    lit = scene(world_state(1))  # the LEDs light up: a new look
    assert lit.entities[0].timestamp != first.entities[0].timestamp
    assert lit.entities[1:] == first.entities[1:], "the people and the ball, as first drawn"
    grown = world_state(2)
    child = msgspec.structs.replace(grown.humans[0], radius_m=0.3)
    grown = msgspec.structs.replace(grown, humans=(child, *grown.humans[1:]))
    redrawn = scene(grown)
    assert redrawn.entities[1].cylinders[0].size.x == 0.6
    assert redrawn.entities[2:] == first.entities[2:]
    same = msgspec.structs.replace(grown, tick=3)
    assert [topic for topic, _ in views.world(same, 3 * TICK_NS)] == ["/foxglove/tf"]
