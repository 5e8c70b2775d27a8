"""ROS 2 message types as DDS sees them: IDL structs with the names and field order of
ROS 2's generated types, so that oimi's samples are ROS 2 messages on the wire.

ROS 2 names a message ``pkg/msg/Name`` and its DDS type ``pkg::msg::dds_::Name_``; every
type here is final (XCDR1, as rmw_cyclonedds uses) and its fields follow the ``.msg``
files of ROS 2's ``common_interfaces``/``rcl_interfaces`` and of ``ros2/oimi_msgs``.
``ROS_TYPES`` maps each ROS 2 name to its class; ``encode``/``decode`` give CDR bytes
(with the 4-byte encapsulation header, as rosbag2 stores them).
"""

# No ``from __future__ import annotations``: cyclonedds resolves the field types at runtime.

from dataclasses import dataclass, field
from typing import Final

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.annotations import final
from cyclonedds.idl.types import array, float32, float64, int32, sequence, uint8, uint32


@final
@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32 = 0
    nanosec: uint32 = 0


@final
@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@final
@dataclass
class String(IdlStruct, typename="std_msgs::msg::dds_::String_"):
    data: str = ""


@final
@dataclass
class ColorRGBA(IdlStruct, typename="std_msgs::msg::dds_::ColorRGBA_"):
    r: float32 = 0.0
    g: float32 = 0.0
    b: float32 = 0.0
    a: float32 = 0.0


@final
@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@final
@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@final
@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@final
@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0
    w: float64 = 1.0


@final
@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@final
@dataclass
class PoseWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose = field(default_factory=Pose)
    covariance: array[float64, 36] = field(default_factory=lambda: [0.0] * 36)


@final
@dataclass
class TwistWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::TwistWithCovariance_"):
    twist: Twist = field(default_factory=Twist)
    covariance: array[float64, 36] = field(default_factory=lambda: [0.0] * 36)


@final
@dataclass
class Odometry(IdlStruct, typename="nav_msgs::msg::dds_::Odometry_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@final
@dataclass
class Joy(IdlStruct, typename="sensor_msgs::msg::dds_::Joy_"):
    header: Header = field(default_factory=Header)
    axes: sequence[float32] = field(default_factory=list)
    buttons: sequence[int32] = field(default_factory=list)


@final
@dataclass
class MapUpdate(IdlStruct, typename="oimi_msgs::msg::dds_::MapUpdate_"):
    objectid: str = ""
    attributename: str = ""
    policy: str = ""
    jsonmsg: str = ""


@final
@dataclass
class RuleMessage(IdlStruct, typename="oimi_msgs::msg::dds_::RuleMessage_"):
    rulecode: int32 = 0
    id: str = ""
    intopic: str = ""
    outtopic: str = ""
    action: uint8 = 0
    mutexcmd: uint8 = 0


@final
@dataclass
class ScriptInfo(IdlStruct, typename="oimi_msgs::msg::dds_::ScriptInfo_"):
    currentactivity: str = ""
    scriptpath: str = ""
    goalid: str = ""
    actionid: str = ""
    blockid: str = ""
    goalname: str = ""
    submove: int32 = 0
    subled: int32 = 0
    subaout: int32 = 0
    block: str = ""
    script_vect: sequence[str] = field(default_factory=list)


ROS_TYPES: Final[dict[str, type[IdlStruct]]] = {
    "std_msgs/msg/String": String,
    "std_msgs/msg/ColorRGBA": ColorRGBA,
    "geometry_msgs/msg/Twist": Twist,
    "nav_msgs/msg/Odometry": Odometry,
    "sensor_msgs/msg/Joy": Joy,
    "oimi_msgs/msg/MapUpdate": MapUpdate,
    "oimi_msgs/msg/RuleMessage": RuleMessage,
    "oimi_msgs/msg/ScriptInfo": ScriptInfo,
}
"""The ROS 2 message types oimi publishes or subscribes to, by ROS 2 name."""

OIMI_MSGS: Final = ("MapUpdate", "RuleMessage", "ScriptInfo")
"""oimi's own interface package's messages (``ros2/oimi_msgs/msg/NAME.msg``)."""


def ros_name(kind: type[IdlStruct]) -> str:
    """A type's ROS 2 name (``geometry_msgs/msg/Twist``)."""
    return next(name for name, k in ROS_TYPES.items() if k is kind)


def stamp(time_ns: int) -> Time:
    """A ROS 2 time from nanoseconds."""
    sec, nanosec = divmod(time_ns, 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


def encode(sample: IdlStruct) -> bytes:
    """The sample's CDR bytes, encapsulation header first (little-endian, XCDR1)."""
    return sample.serialize(use_version_2=False)


def decode(kind: type[IdlStruct], data: bytes | memoryview) -> IdlStruct:
    """A sample of ``kind`` from CDR bytes with their encapsulation header."""
    return kind.deserialize(bytes(data), has_header=True)
