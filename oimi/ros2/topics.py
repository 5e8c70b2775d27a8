"""The ROS 2 topics oimi speaks: name and type (who publishes what: ``docs/ros2.md``)."""

from __future__ import annotations

from typing import Final

import msgspec
from cyclonedds.idl import IdlStruct

from oimi.ros2 import types


class RosTopic(msgspec.Struct, frozen=True):
    """A ROS 2 topic: its name (``/cmd_vel``) and message type."""

    name: str
    kind: type[IdlStruct]

    @property
    def dds_name(self) -> str:
        """The DDS topic ROS 2 uses for it (``rt/cmd_vel``)."""
        return "rt" + self.name

    @property
    def type_name(self) -> str:
        """The ROS 2 message type (``geometry_msgs/msg/Twist``)."""
        return types.ros_name(self.kind)


# The robot's side publishes these; oimi bridge reads them.
MAP_UPDATES: Final = RosTopic("/oimi/map_updates", types.MapUpdate)
JOY: Final = RosTopic("/joy", types.Joy)
ODOM: Final = RosTopic("/odom", types.Odometry)
# oimi bridge publishes these: the body's commands (cmd_vel every tick, LED and audio
# on change; audio is the track playing, "" for silence) ...
CMD_VEL: Final = RosTopic("/cmd_vel", types.Twist)
LED: Final = RosTopic("/oimi/led", types.ColorRGBA)
AUDIO: Final = RosTopic("/oimi/audio", types.String)
# ... and what the mind does: script progress, alfa/omega messages, rule decisions (JSON).
SCRIPT_INFO: Final = RosTopic("/oimi/script_info", types.ScriptInfo)
RULE_MESSAGES: Final = RosTopic("/oimi/rule_messages", types.RuleMessage)
RULE_DECISIONS: Final = RosTopic("/oimi/rule_decisions", types.String)
# Only in rosbag2 exports: the operator's commands (JSON), read back by oimi replay.
OPERATOR_COMMANDS: Final = RosTopic("/oimi/operator_commands", types.String)

ODOM_FRAME: Final = "odom"
BASE_FRAME: Final = "base_link"
