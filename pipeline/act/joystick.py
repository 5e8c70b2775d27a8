"""The Xbox 360 pad's mapping (thesis 3.2, 5.3 and figure 5.17).

| control            | meaning                                                     |
|--------------------|-------------------------------------------------------------|
| ``LB`` held        | safety lock (dead-man): without it every input is ignored   |
| left stick y       | forward speed ``v_x``                                       |
| left stick x       | lateral speed ``v_y = -left_x`` (stick right = move right)  |
| right stick x      | angular speed ``v_theta = -right_x`` (stick right = turn right) |
| ``RB`` held + lock | blocking mode: the block's clock freezes while driving      |
| ``X`` + lock       | interrupt block execution until the lock's next engagement  |

Full deflection is the robot's limits; a dead-zone of 0.1 (scaled, so speed grows
continuously from 0 at its edge) keeps a resting stick from creeping. The left
stick is limited to the unit circle, so a diagonal is as fast as a straight push.
"""

from __future__ import annotations

import math
from typing import Final, NamedTuple

from oimi.pipeline.act.limits import RobotLimits, Velocity, fmt
from oimi.pipeline.events import Button, JoystickInput

DEAD_ZONE: Final = 0.1
"""Stick deflections below this (of 1) count as 0."""


SAFETY_LOCK: Final = Button.LB
BLOCKING: Final = Button.RB
INTERRUPT: Final = Button.X


class PadReading(NamedTuple):
    """A pad input read against the mapping: what it asks, and notes on what was odd."""

    lock: bool
    blocking: bool
    interrupt: bool
    velocity: Velocity
    """What the sticks ask, within the limits."""
    neutral: bool
    """No stick outside the dead-zone and no button held."""
    notes: tuple[str, ...]


def _dead_zone(magnitude: float) -> float:
    """A deflection in [0, 1] with the dead-zone cut out and the rest rescaled to [0, 1]."""
    if magnitude <= DEAD_ZONE:
        return 0.0
    return (min(magnitude, 1.0) - DEAD_ZONE) / (1.0 - DEAD_ZONE)


def read_pad(pad: JoystickInput, limits: RobotLimits) -> PadReading:
    """The pad's state under the mapping above."""
    notes: list[str] = []
    held: list[Button] = []
    for name in pad.buttons:
        try:
            held.append(Button(name))
        except ValueError:
            notes.append(f"joystick: unknown button {name!r} ignored")
    axes = {"left_x": pad.left_x, "left_y": pad.left_y, "right_x": pad.right_x}
    for name, value in axes.items():
        if not math.isfinite(value):
            notes.append(f"joystick: {name} {value!r} is not a number, read as 0.0")
            axes[name] = 0.0
        elif abs(value) > 1.0:
            notes.append(f"joystick: {name} {fmt(value)} outside [-1, 1], limited to the edge")
    left_x, left_y, right_x = axes["left_x"], axes["left_y"], axes["right_x"]
    left = math.hypot(left_x, left_y)
    if left > 0.0:
        scale = _dead_zone(left) / left * limits.max_speed_mps
        v_x, v_y = left_y * scale, -left_x * scale
    else:
        v_x = v_y = 0.0
    turn = math.copysign(_dead_zone(abs(right_x)), right_x)
    v_theta = -turn * limits.max_angular_speed_radps
    velocity = Velocity(v_x + 0.0, v_y + 0.0, v_theta + 0.0)
    return PadReading(
        lock=SAFETY_LOCK in held,
        blocking=BLOCKING in held,
        interrupt=INTERRUPT in held,
        velocity=velocity,
        neutral=not pad.buttons and velocity == (0.0, 0.0, 0.0),
        notes=tuple(notes),
    )
