"""The ROS 2 edge's small parts: the pad as joy_node reports it, the closed-by-default
network, the remote sensors' refusals, the bridge's session without a simulated world and
its stop when a tick is late (the robot's clock: ``test_ros2_clock.py``)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds) is not installed")

from oimi.pipeline.messages import Policy
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session import runner

from oimi.cli import main
from oimi.live.inputs import Pad
from oimi.ros2 import topics, types
from oimi.ros2.bridge import BridgeSession
from oimi.ros2.joy import joy_of, pad_of
from oimi.ros2.network import Network, NetworkError, domain_id_from
from oimi.ros2.remote import RemoteBody, RemoteSensors

ROOM = Path(__file__).with_name("ros2_room.toml")


def test_joy_node_axes_are_read_with_x_flipped_and_lb_on_button_4():
    joy = types.Joy(axes=[0.5, 0.75, 1.0, -0.25, 0.0, 1.0], buttons=[0, 0, 1, 0, 1, 0, 0, 0])
    assert pad_of(joy) == Pad(left_x=-0.5, left_y=0.75, right_x=0.25, buttons=("X", "LB"))


def test_a_short_joy_reads_as_centred_and_released():
    assert pad_of(types.Joy(axes=[0.0, 1.0], buttons=[1])) == Pad(left_y=1.0, buttons=("A",))
    assert not pad_of(types.Joy()).locked


@pytest.mark.parametrize(
    "pad",
    [
        Pad(),
        Pad(left_x=0.5, left_y=-1.0, right_x=-0.25, buttons=("LB",)),
        Pad(right_x=1.0, buttons=("A", "X", "LB", "RB", "START")),
    ],
)
def test_a_pad_survives_joy_and_back(pad):
    joy = joy_of(pad, time_ns=1_250_000_000)
    assert (joy.header.stamp.sec, joy.header.stamp.nanosec) == (1, 250_000_000)
    back = pad_of(types.decode(types.Joy, types.encode(joy)))
    assert (back.left_x, back.left_y, back.right_x) == (pad.left_x, pad.left_y, pad.right_x)
    assert sorted(back.buttons) == sorted(pad.buttons)


def test_the_default_network_is_loopback_without_multicast():
    xml = Network().xml()
    assert '<NetworkInterface address="127.0.0.1"/>' in xml
    assert "<AllowMulticast>false</AllowMulticast>" in xml
    assert '<Peer address="localhost"/>' in xml
    named = Network(interface="eth0", peers=("192.168.1.20",)).xml()
    assert '<NetworkInterface name="eth0"/>' in named and "192.168.1.20" in named


def test_the_domain_comes_from_ros_domain_id():
    assert domain_id_from({}) == 0
    assert domain_id_from({"ROS_DOMAIN_ID": " 42 "}) == 42
    for bad in ("x", "-1", "233"):
        with pytest.raises(NetworkError, match=r"ROS_DOMAIN_ID: .* is not a domain id"):
            domain_id_from({"ROS_DOMAIN_ID": bad})


def test_a_bad_domain_id_is_refused_before_any_traffic(monkeypatch, capsys):
    monkeypatch.setenv("ROS_DOMAIN_ID", "999")
    room = str(ROOM)
    assert main(["sim", "--ros2", room, "--duration-s", "1"]) == 2
    assert "ROS_DOMAIN_ID: '999' is not a domain id" in capsys.readouterr().err


def test_sim_warns_of_a_sonar_ring_too_short_for_the_robot(monkeypatch, capsys, tmp_path):
    short = tmp_path / "short.toml"
    short.write_text(ROOM.read_text().replace("[sensors]\n", "[sensors]\nsonar_range_m = 0.4\n"))
    shutil.copytree(ROOM.parent / "activities", tmp_path / "activities")
    monkeypatch.setenv("ROS_DOMAIN_ID", "999")  # stops it before any traffic
    assert main(["sim", "--ros2", str(short), "--duration-s", "1"]) == 2
    err = capsys.readouterr().err
    assert "sensors.sonar_range_m (m): the sonar ring reaches 0.4 m" in err
    assert "(warning)" in err


def test_remote_sensors_number_updates_in_arrival_order_and_refuse_bad_policies():
    sensors = RemoteSensors()
    sensors.receive(types.MapUpdate(objectid="Camera/front", attributename="isonline", policy="R"))
    sensors.receive(types.MapUpdate(objectid="Human/c", attributename="poses", policy="X"))
    sensors.receive(types.MapUpdate(objectid="Human/c", attributename="poses", policy="A"))
    updates = sensors.sample(None, tick=0, time_ms=0)
    assert [(u.seq, u.policy) for u in updates] == [(1, Policy.R), (2, Policy.A)]
    assert sensors.refused == [
        "map update for 'Human/c'/'poses' refused: policy 'X' is not 'R' or 'A'"
    ]
    assert sensors.sample(None, tick=1, time_ms=20) == []


class _NoDds:
    """A stand-in for the DDS node: readers and writers that are never used here."""

    network = Network()

    def reader(self, topic: object, **options: object) -> None:
        return None

    def writer(self, topic: object, **options: object) -> None:
        return None


def test_the_bridge_builds_the_pipeline_without_a_simulated_world(monkeypatch):
    def no_world(*args: object, **kwargs: object) -> None:
        raise AssertionError("the bridge built a simulated world")

    monkeypatch.setattr(runner, "World", no_world)  # where a session builds one
    monkeypatch.setattr(runner, "Sensors", no_world)
    session = BridgeSession(load_scenario(ROOM), _NoDds())  # type: ignore[arg-type]
    assert isinstance(session.world, RemoteBody) and session.world is session.body
    assert session.sensors is session.remote_sensors
    assert session.pipeline is session.built.pipeline
    state = session.world.state(tick=0, time_ms=0)
    assert (state.robot.x_m, state.robot.radius_m) == (0.0, session.scenario.robot.radius_m)


class _Writers(_NoDds):
    """A stand-in node whose writers keep what they are given, by topic."""

    def __init__(self) -> None:
        self.written: dict[str, list[object]] = {}

    def writer(self, topic: object, **options: object) -> object:
        sent = self.written.setdefault(str(getattr(topic, "name", topic)), [])
        return type("Writer", (), {"write": staticmethod(sent.append)})()


def test_a_late_tick_tells_the_robot_to_stand_still_at_once():
    node = _Writers()
    notes: list[str] = []
    session = BridgeSession(load_scenario(ROOM), node, on_note=notes.append)  # type: ignore[arg-type]
    session.late()  # from the watchdog's thread, while a tick holds the main one
    (twist,) = node.written[str(topics.CMD_VEL.name)]
    assert twist == types.Twist(linear=types.Vector3(), angular=types.Vector3())
    assert notes == ["a tick is late: the robot is told to stand still until it ends"]
