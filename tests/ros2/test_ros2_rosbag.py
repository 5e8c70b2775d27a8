"""rosbag2 both ways: a recording exported (MCAP storage, zstd, oimi_msgs) is read back by
rosbags with its counts and values, and driving the pipeline over the bag gives the
session's pipeline messages again, byte for byte."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds) is not installed")
pytest.importorskip("rosbags", reason="the ros2 extra (rosbags) is not installed")

from mcap.reader import make_reader
from oimi.pipeline.events import JoystickInput, SensorUpdates, Topic
from oimi.recorder.reader import open_recording
from oimi.scenarios.real_robot import REAL_SURFACE
from oimi.scenarios.session import runner
from rosbags.highlevel import AnyReader

from oimi.cli import main
from oimi.ros2.bag import typestore

LIBRARY = Path(__file__).resolve().parents[2] / "scenarios" / "library"
SCENARIO = LIBRARY / "joystick_takeover.toml"


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The joystick takeover scenario recorded, then exported as a rosbag2."""
    folder = tmp_path_factory.mktemp("rosbag")
    recording, bag = folder / "session.mcap", folder / "bag"
    assert main(["run", str(SCENARIO), "-o", str(recording)]) == 0
    assert main(["export", "--ros2", str(recording), str(bag)]) == 0
    return recording, bag


def test_rosbags_reads_the_export_with_its_counts_and_values(exported):
    recording, bag = exported
    session = open_recording(recording)
    updates = [
        u for e in session.iter_messages([Topic.SENSOR_UPDATES]) for u in e.decoded().updates
    ]
    pads = [m.decoded() for m in session.iter_messages([Topic.JOYSTICK])]
    ticks = session.summary[Topic.WORLD_STATE.value]
    with AnyReader([bag], default_typestore=typestore()) as reader:
        kinds = {c.topic: c.msgtype for c in reader.connections}
        assert kinds["/oimi/map_updates"] == "oimi_msgs/msg/MapUpdate"
        assert kinds["/joy"] == "sensor_msgs/msg/Joy"
        assert kinds["/cmd_vel"] == "geometry_msgs/msg/Twist"
        assert kinds["/odom"] == "nav_msgs/msg/Odometry"
        counts = {c.topic: c.msgcount for c in reader.connections}
        assert counts["/oimi/map_updates"] == len(updates)
        assert counts["/odom"] == ticks
        got = {"/oimi/map_updates": [], "/joy": []}
        wanted = [c for c in reader.connections if c.topic in got]
        for connection, time_ns, raw in reader.messages(connections=wanted):
            got[connection.topic].append((time_ns, reader.deserialize(raw, connection.msgtype)))
    first, message = updates[0], got["/oimi/map_updates"][0][1]
    assert (message.objectid, message.attributename, message.policy, message.jsonmsg) == (
        first.objectid,
        first.attributename,
        str(first.policy),
        first.jsonmsg,
    )
    # The pad: every recorded state at its tick's time, LB on button 4, the right
    # stick's x with joy_node's sign (left positive); held states repeated as joy_node does.
    times = {t for t, _ in got["/joy"]}
    assert all(p.time_ms * 1_000_000 in times for p in pads)
    turning = next(p for p in pads if isinstance(p, JoystickInput) and p.right_x)
    joy = dict(got["/joy"])[turning.time_ms * 1_000_000]
    assert joy.buttons[4] == 1 and joy.axes[3] == -turning.right_x
    assert len(got["/joy"]) > len(pads)


def test_the_export_is_mcap_storage_with_zstd_chunks(exported):
    _, bag = exported
    (file,) = bag.glob("*.mcap")
    with file.open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
        assert {c.message_encoding for c in summary.channels.values()} == {"cdr"}
        assert {c.compression for c in summary.chunk_indexes} == {"zstd"}
    assert "storage_identifier: mcap" in (bag / "metadata.yaml").read_text()


def test_driving_the_pipeline_over_the_bag_gives_the_session_again(exported, tmp_path, monkeypatch):
    recording, bag = exported

    def no_world(*args: object, **kwargs: object) -> None:
        raise AssertionError("a simulated world was built for the bag")

    monkeypatch.setattr(runner, "World", no_world)  # where a session builds one
    monkeypatch.setattr(runner, "Sensors", no_world)
    again = tmp_path / "again.mcap"
    code = main(["replay", str(bag), "--scenario", str(SCENARIO), "-o", str(again)])
    assert code == 0
    before, after = open_recording(recording), open_recording(again)
    for topic in Topic:
        if topic is Topic.WORLD_STATE:  # the world is the odometry now: no people
            continue
        recorded = [m.payload_bytes for m in before.iter_messages([topic])]
        driven = [m.payload_bytes for m in after.iter_messages([topic])]
        assert driven == recorded, topic
    assert any(isinstance(m.decoded(), SensorUpdates) for m in after.iter_messages())
    # the lab camera's range and ring's echoes, left out of the scenario: the supervisor's own
    assert after.meta.variation == {"robot.safety.camera_range_m": "3.0"} | REAL_SURFACE
    assert main(["replay", str(again)]) == 0  # and the drive itself redrives


def test_a_bag_without_a_scenario_or_not_a_bag_is_refused(exported, tmp_path, capsys):
    _, bag = exported
    assert main(["replay", str(bag)]) == 2
    assert "give --scenario" in capsys.readouterr().err
    for extra in ([], ["--scenario", str(SCENARIO)]):  # any folder is not a rosbag2
        assert main(["replay", str(tmp_path), *extra]) == 2
        assert f"{tmp_path}: cannot read: a folder, but not a rosbag2" in capsys.readouterr().err
    assert main(["export", "--ros2", str(exported[0]), str(bag)]) == 2
    assert "exists already" in capsys.readouterr().err
    assert main(["replay", str(bag), "--mode", "rerun", "--scenario", str(SCENARIO)]) == 2
    assert "--mode does not apply" in capsys.readouterr().err
    assert main(["replay", str(exported[0]), "--scenario", str(SCENARIO)]) == 2
    assert "are for a rosbag2 folder" in capsys.readouterr().err
