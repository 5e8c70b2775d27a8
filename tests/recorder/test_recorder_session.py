"""Recordings of a real session: every topic, schema-valid, rebuildable, byte-stable, in Rerun."""

from __future__ import annotations

import json
import subprocess
import sys
from collections import Counter
from pathlib import Path

import jsonschema
import msgspec
import pytest
from mcap.reader import make_reader
from oimi.pipeline.events import TOPIC_TYPES, Topic
from oimi.pipeline.sink import MemorySink
from oimi.recorder.reader import Recording, open_recording
from oimi.recorder.topics import schema_data
from oimi.scenarios import loader
from oimi.scenarios.loader import parse_scenario
from oimi.scenarios.session import runner
from oimi.scenarios.session.recording import recorded
from oimi.scenarios.session.runner import Session
from recorder_foxglove_paths import FOXGLOVE_SCHEMAS
from rerun.chunk import RrdReader

REPO = Path(__file__).resolve().parents[2]
SCENARIO = b"""\
name = "busy"
description = "Four busy seconds: two humans, a generator, a script, a touch, a rejected command."
# the joystick drives at the child: the safety supervisor slows it (a /safety event)
seed = 3
duration_s = 4.0

[world]
obstacles = [{ id = "table", kind = "table", x_m = 1.0, y_m = 4.3, width_m = 1.2, height_m = 0.8 }]
objects = [{ id = "ball", x_m = 2.0, y_m = 1.5 }]

[robot]
x_m = 3.0
y_m = 2.5

[robot.safety]
slow_distance_m = 1.0

[sensors]
noise_rho_m = 0.02
dropout_probability = 0.1

[[humans]]
id = "child"
x_m = 5.0
y_m = 2.6
behaviour = [{ kind = "approach", distance_m = 1.0, speed_mps = 0.4 }]

[[humans]]
id = "therapist"
role = "therapist"
x_m = 1.5
y_m = 1.0
behaviour = [{ kind = "wander", pause_s = 0.5 }]

[[activities]]
generator = "greeting"

[[activities]]
script = "activities/wait_for_child.txt"

[[events]]
kind = "operator"
at_s = 1.0
command = { cmd = "remove", activity = "no_such_activity" }

[[events]]
kind = "touch"
at_s = 1.5
human = "child"
touchtype = "C"

[[events]]
kind = "joystick"
at_s = 2.0
left_y = 1.0
buttons = ["LB"]
hold_s = 0.5
"""


class Recorded(msgspec.Struct, frozen=True, kw_only=True):
    scenario: Path
    mcap: Path
    rrd: Path


@pytest.fixture(scope="module")
def session_files(tmp_path_factory: pytest.TempPathFactory) -> Recorded:
    folder = tmp_path_factory.mktemp("session")
    scenario = folder / "busy.toml"
    scenario.write_bytes(SCENARIO)
    files = Recorded(scenario=scenario, mcap=folder / "busy.mcap", rrd=folder / "busy.rrd")
    session = Session(loader.load_scenario(scenario))
    with recorded(session, mcap=files.mcap, rrd=files.rrd):
        session.run()
    return files


@pytest.fixture(scope="module")
def recording(session_files: Recorded) -> Recording:
    return open_recording(session_files.mcap)


def test_every_topic_is_recorded_and_every_message_decodes_into_its_struct(
    recording: Recording,
) -> None:
    assert recording.recovery is None
    counts: Counter[str] = Counter()
    for message in recording.iter_messages():
        assert isinstance(message.decoded(), TOPIC_TYPES[message.topic])
        counts[message.topic] += 1
    assert set(counts) == set(Topic)
    assert dict(counts) == {t: recording.summary[t] for t in Topic}
    assert counts[Topic.WORLD_STATE] == 101  # 4 s at 50 Hz: every second tick and the last


def validator(schema_name: str, schema_data: bytes) -> jsonschema.protocols.Validator:
    """Our channels carry their schema; Foxglove's are checked against Foxglove's own files."""
    if schema_name.startswith("foxglove."):
        path = FOXGLOVE_SCHEMAS / f"{schema_name.removeprefix('foxglove.')}.json"
        schema = json.loads(path.read_text())
    else:
        schema = json.loads(schema_data)
    cls = jsonschema.validators.validator_for(schema, default=jsonschema.Draft202012Validator)
    cls.check_schema(schema)
    return cls(schema)


def test_every_message_validates_against_its_channels_json_schema(
    session_files: Recorded,
) -> None:
    validators: dict[int, jsonschema.protocols.Validator] = {}
    checked: Counter[str] = Counter()
    with open(session_files.mcap, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            assert schema is not None and schema.encoding == "jsonschema"
            assert channel.message_encoding == "json"
            if channel.id not in validators:
                validators[channel.id] = validator(schema.name, schema.data)
            validators[channel.id].validate(json.loads(message.data))
            checked[channel.topic] += 1
    assert set(Topic) <= set(checked)
    assert {"/foxglove/scene", "/foxglove/tf", "/foxglove/log"} <= set(checked)


def test_foxglove_draws_every_body_where_the_world_state_has_it(session_files: Recorded) -> None:
    """Each body is drawn in its own frame: every transform puts it where ``/world/state``
    has it at that time, and every scene entity is locked to a frame the transforms move."""
    states: dict[int, dict[str, tuple[float, float]]] = {}
    transforms: list[tuple[int, dict]] = []
    frames_drawn: set[str] = set()
    with session_files.mcap.open("rb") as stream:
        for _, channel, message in make_reader(stream).iter_messages():
            data = json.loads(message.data)
            if channel.topic == Topic.WORLD_STATE:
                where = {"robot": _xy(data["robot"])}
                where |= {f"human/{h['id']}": _xy(h) for h in data["humans"]}
                where |= {f"object/{o['id']}": _xy(o) for o in data["objects"]}
                states[message.log_time] = where
            elif channel.topic == "/foxglove/tf":
                transforms.append((message.log_time, data))
            elif channel.topic == "/foxglove/scene":
                assert all(e["frame_locked"] for e in data["entities"])
                frames_drawn |= {e["frame_id"] for e in data["entities"]}
    assert len(transforms) == 40  # every fifth tick of 200
    moved, checked = set(), 0
    for time_ns, tf in transforms:
        where = {t["child_frame_id"]: _xy(t["translation"], "x", "y") for t in tf["transforms"]}
        if time_ns in states:  # the recording keeps every second tick's state
            assert where == states[time_ns]
            checked += 1
        moved |= set(where)
    assert checked == 20
    assert frames_drawn and frames_drawn <= moved


def _xy(body: dict, x: str = "x_m", y: str = "y_m") -> tuple[float, float]:
    return body[x], body[y]


@pytest.mark.parametrize("topic", list(Topic))
def test_every_topic_schema_is_self_contained(topic: Topic) -> None:
    """Viewers without ``$ref`` support read them: no reference is left, not even a tagged
    union's discriminator mapping (the operator's commands)."""
    assert b"$defs" not in schema_data(topic) and b"$ref" not in schema_data(topic)


def test_metadata_and_attachments_alone_rebuild_the_same_run(
    recording: Recording, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Nothing from the shipped library: every script must come from the recording.
    empty = tmp_path / "no-library"
    (empty / "activities").mkdir(parents=True)
    monkeypatch.setattr(runner, "ACTIVITIES", empty / "activities")
    monkeypatch.setattr(loader, "LIBRARY_DIR", empty)
    rebuilt = tmp_path / "rebuilt"
    (rebuilt / "activities").mkdir(parents=True)
    scenario_files = [n for n in recording.attachments if n.startswith("scenario/")]
    assert len(scenario_files) == 1
    for name, data in recording.attachments.items():
        if name.startswith("activities/"):
            (rebuilt / name).write_bytes(data)
    meta = recording.metadata
    source = rebuilt / meta["scenario"]["file"]
    loaded = parse_scenario(
        recording.attachments[scenario_files[0]], source=source, base_dir=rebuilt
    )
    session = Session(loaded, seed=int(meta["scenario"]["seed"]), overrides=meta.get("variation"))
    memory = MemorySink()
    session.sink.add(memory)
    session.run()

    assert session.metadata().records()["configuration"] == meta["configuration"]
    assert session.metadata().oimi.rule_registry == meta["oimi"]["rule_registry"]
    encode = msgspec.json.encode
    again = [encode(e) for e in memory.on(Topic.ACTUATOR_COMMANDS)]
    assert again == [m.payload_bytes for m in recording.iter_messages([Topic.ACTUATOR_COMMANDS])]
    assert len(again) > 0
    states = {e.tick: encode(e) for e in memory.on(Topic.WORLD_STATE)}
    kept = [(m.tick, m.payload_bytes) for m in recording.iter_messages([Topic.WORLD_STATE])]
    assert len(kept) == 101 and all(states[tick] == payload for tick, payload in kept)


def test_two_runs_in_separate_processes_write_byte_identical_files(
    session_files: Recorded, tmp_path: Path
) -> None:
    outputs = [tmp_path / "a.mcap", tmp_path / "b.mcap"]
    for output in outputs:
        command = ["oimi", "run", str(session_files.scenario), "-o", str(output), "-q"]
        subprocess.run(
            [sys.executable, "-m", *command],
            cwd=REPO,
            check=True,
            capture_output=True,
        )
    first, second = (o.read_bytes() for o in outputs)
    assert first == second
    assert first == session_files.mcap.read_bytes()  # and the same as in-process


def test_the_rrd_holds_the_world_robot_humans_rules_and_log(session_files: Recorded) -> None:
    reader = RrdReader(session_files.rrd)
    assert [r.recording_id for r in reader.recordings()] == ["busy-seed3"]
    rows: Counter[str] = Counter()
    for chunk in reader.stream().to_chunks():
        rows[chunk.entity_path] += chunk.num_rows
        if not chunk.is_static:
            rows["temporal " + chunk.entity_path] += chunk.num_rows
    for entity in (
        "/world/arena",
        "/world/robot",
        "/world/humans/child",
        "/world/humans/therapist",
        "/world/objects/ball",
        "/rules/decisions",
        "/log",
        "/script/block",
    ):
        assert rows[entity] > 0, entity
    assert rows["temporal /world/robot"] == 40  # every 5th of 200 ticks
