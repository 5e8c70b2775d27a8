"""oimi's ROS 2 messages are ROS 2's on the wire: the same CDR bytes as rosbags serializes,
the same fields in the same order as the .msg definitions."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds) is not installed")
pytest.importorskip("rosbags", reason="the ros2 extra (rosbags) is not installed")

from oimi.ros2 import types
from oimi.ros2.bag import typestore

STORE = typestore()
R = STORE.types


def ros_twist(lx: float, ly: float, az: float) -> object:
    v3 = R["geometry_msgs/msg/Vector3"]
    return R["geometry_msgs/msg/Twist"](
        linear=v3(x=lx, y=ly, z=0.0), angular=v3(x=0.0, y=0.0, z=az)
    )


def ros_joy(sec: int, nanosec: int, frame: str, axes: list[float], buttons: list[int]) -> object:
    return R["sensor_msgs/msg/Joy"](
        header=R["std_msgs/msg/Header"](
            stamp=R["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame
        ),
        axes=np.array(axes, dtype=np.float32),
        buttons=np.array(buttons, dtype=np.int32),
    )


def rosbags_bytes(message: object, name: str) -> bytes:
    return bytes(STORE.serialize_cdr(message, name))


def test_twist_bytes_equal_rosbags():
    ours = types.encode(
        types.Twist(linear=types.Vector3(x=0.2, y=-0.1), angular=types.Vector3(z=1.5))
    )
    assert ours == rosbags_bytes(ros_twist(0.2, -0.1, 1.5), "geometry_msgs/msg/Twist")
    assert ours[:4] == b"\x00\x01\x00\x00"  # CDR little-endian, as rmw_cyclonedds sends


def test_joy_bytes_equal_rosbags():
    ours = types.encode(
        types.Joy(
            header=types.Header(stamp=types.Time(sec=3, nanosec=5), frame_id="joy"),
            axes=[0.5, -1.0, 0.25],
            buttons=[0, 1, 0, 0, 1],
        )
    )
    theirs = rosbags_bytes(
        ros_joy(3, 5, "joy", [0.5, -1.0, 0.25], [0, 1, 0, 0, 1]), "sensor_msgs/msg/Joy"
    )
    assert ours == theirs


def test_map_update_bytes_equal_rosbags():
    fields = {
        "objectid": "Human/child",
        "attributename": "poses",
        "policy": "A",
        "jsonmsg": '{"positionrho": 1.25, "positiontheta": -0.5, "positionchangetime": 40}',
    }
    ours = types.encode(types.MapUpdate(**fields))
    theirs = rosbags_bytes(R["oimi_msgs/msg/MapUpdate"](**fields), "oimi_msgs/msg/MapUpdate")
    assert ours == theirs


def test_decoding_rosbags_bytes_gives_the_message_back():
    data = rosbags_bytes(ros_joy(7, 9, "pad", [1.0, -0.5], [1, 0, 1]), "sensor_msgs/msg/Joy")
    joy = types.decode(types.Joy, data)
    assert (joy.header.stamp.sec, joy.header.stamp.nanosec, joy.header.frame_id) == (7, 9, "pad")
    assert (list(joy.axes), list(joy.buttons)) == ([1.0, -0.5], [1, 0, 1])


@pytest.mark.parametrize("name", sorted(types.ROS_TYPES))
def test_field_names_and_order_follow_the_msg_definitions(name):
    theirs = [field[0] for field in STORE.get_msgdef(name).fields]
    ours = list(types.ROS_TYPES[name].__annotations__)
    assert ours == theirs


def test_type_names_are_ros2_dds_names():
    assert types.Twist.__idl_typename__ == "geometry_msgs::msg::dds_::Twist_"
    assert types.MapUpdate.__idl_typename__ == "oimi_msgs::msg::dds_::MapUpdate_"
    assert types.Joy.__idl_typename__ == "sensor_msgs::msg::dds_::Joy_"


def _f32(value: float) -> float:
    return struct.unpack("<f", struct.pack("<f", value))[0]


texts = st.text(max_size=40)
floats32 = st.floats(min_value=-1e6, max_value=1e6, width=32)


@settings(derandomize=True, max_examples=60, deadline=None)
@given(
    objectid=texts,
    attributename=texts,
    policy=st.sampled_from(["R", "A", ""]),
    jsonmsg=texts,
    axes=st.lists(floats32, max_size=8),
    buttons=st.lists(st.integers(min_value=-(2**31), max_value=2**31 - 1), max_size=12),
    sec=st.integers(min_value=0, max_value=2**31 - 1),
)
def test_any_map_update_and_joy_encode_as_rosbags_does(
    objectid, attributename, policy, jsonmsg, axes, buttons, sec
):
    update = {"objectid": objectid, "attributename": attributename}
    update |= {"policy": policy, "jsonmsg": jsonmsg}
    assert types.encode(types.MapUpdate(**update)) == rosbags_bytes(
        R["oimi_msgs/msg/MapUpdate"](**update), "oimi_msgs/msg/MapUpdate"
    )
    axes = [_f32(a) for a in axes]
    ours = types.Joy(
        header=types.Header(stamp=types.Time(sec=sec, nanosec=1), frame_id=objectid),
        axes=axes,
        buttons=buttons,
    )
    theirs = ros_joy(sec, 1, objectid, axes, buttons)
    assert types.encode(ours) == rosbags_bytes(theirs, "sensor_msgs/msg/Joy")


SAMPLES = {
    "std_msgs/msg/String": types.String(data="hello.wav"),
    "std_msgs/msg/ColorRGBA": types.ColorRGBA(r=0.5, g=0.25, b=1.0, a=1.0),
    "geometry_msgs/msg/Twist": types.Twist(angular=types.Vector3(z=-0.75)),
    "nav_msgs/msg/Odometry": None,  # built below from oimi's own helper
    "sensor_msgs/msg/Joy": types.Joy(axes=[0.0, 1.0], buttons=[0, 0, 0, 0, 1]),
    "oimi_msgs/msg/MapUpdate": types.MapUpdate(objectid="Camera/front", policy="R"),
    "oimi_msgs/msg/RuleMessage": types.RuleMessage(
        rulecode=1, id="child_too_close", action=ord("A"), mutexcmd=ord("U")
    ),
    "oimi_msgs/msg/ScriptInfo": types.ScriptInfo(
        currentactivity="drive_slowly", goalid="goal0", submove=1, script_vect=["a", "b"]
    ),
}


@pytest.mark.parametrize("name", sorted(SAMPLES))
def test_every_type_survives_rosbags_byte_for_byte(name):
    from oimi.ros2.remote import odometry

    sample = SAMPLES[name] or odometry(
        time_ns=1_500_000_000, pose=(1.0, 2.0, 0.5), velocity=(0.1, 0.0, -0.2)
    )
    ours = types.encode(sample)
    again = rosbags_bytes(STORE.deserialize_cdr(ours, name), name)
    assert again == ours
