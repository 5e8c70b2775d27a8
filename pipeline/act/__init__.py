"""Act: the Actuator that runs instruction blocks, the robot's limits and the joystick."""

from pipeline.act.actuator import Actuator, ActuatorStep
from pipeline.act.joystick import Button, read_pad
from pipeline.act.limits import RobotLimits, Velocity, clamp_velocity, ramp_velocity

__all__ = [
    "Actuator",
    "ActuatorStep",
    "Button",
    "RobotLimits",
    "Velocity",
    "clamp_velocity",
    "ramp_velocity",
    "read_pad",
]
