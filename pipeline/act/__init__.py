"""Act: the Actuator that runs instruction blocks, the robot's limits, the joystick and the
safety supervisor below them."""

from oimi.pipeline.act.actuator import Actuator, ActuatorStep
from oimi.pipeline.act.joystick import Button, read_pad
from oimi.pipeline.act.limits import RobotLimits, Velocity, clamp_velocity, ramp_velocity
from oimi.pipeline.act.safety import SafetySupervisor
from oimi.pipeline.act.safety_config import SafetyConfig

__all__ = [
    "Actuator",
    "ActuatorStep",
    "Button",
    "RobotLimits",
    "SafetyConfig",
    "SafetySupervisor",
    "Velocity",
    "clamp_velocity",
    "ramp_velocity",
    "read_pad",
]
