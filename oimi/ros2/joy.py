"""The Xbox 360 pad as ``sensor_msgs/Joy`` carries it, read into oimi's pad state.

ROS 2's ``joy_node`` (package ``joy``) reports an Xbox 360 pad with axes
0 left stick x, 1 left stick y, 2 LT, 3 right stick x, 4 right stick y, 5 RT, and
buttons 0 A, 1 B, 2 X, 3 Y, 4 LB, 5 RB, 6 BACK, 7 START. Its sticks are positive to
the *left* and up; oimi's pad is positive to the right and up (``docs/actuator-and-
joystick.md``), so the x axes change sign. A missing axis or button reads as centred
or released.
"""

from __future__ import annotations

import math
from typing import Final

import msgspec

from oimi.pipeline.act.joystick import Button
from oimi.pipeline.events import Pad
from oimi.ros2 import types


class JoyMapping(msgspec.Struct, frozen=True, kw_only=True):
    """Which ``Joy`` axis and button is which control of the pad."""

    left_x: int = 0
    left_y: int = 1
    right_x: int = 3
    x_left_positive: bool = True
    """``joy_node`` reports the sticks' x positive to the left."""
    buttons: tuple[tuple[Button, int], ...] = (
        (Button.A, 0),
        (Button.B, 1),
        (Button.X, 2),
        (Button.Y, 3),
        (Button.LB, 4),
        (Button.RB, 5),
        (Button.BACK, 6),
        (Button.START, 7),
    )


XBOX_360: Final = JoyMapping()


def _axis(axes: list[float], index: int) -> float:
    value = float(axes[index]) if index < len(axes) else 0.0
    return value + 0.0


def pad_of(joy: types.Joy, mapping: JoyMapping = XBOX_360) -> Pad:
    """The pad's state a ``Joy`` message reports (out-of-range or odd values are kept:
    the actuator notes them and limits them, as for any pad)."""
    sign = -1.0 if mapping.x_left_positive else 1.0
    axes, pressed = list(joy.axes), list(joy.buttons)
    return Pad(
        left_x=sign * _axis(axes, mapping.left_x) + 0.0,
        left_y=_axis(axes, mapping.left_y),
        right_x=sign * _axis(axes, mapping.right_x) + 0.0,
        buttons=tuple(
            button for button, index in mapping.buttons if index < len(pressed) and pressed[index]
        ),
    )


def joy_of(pad: Pad, *, time_ns: int, mapping: JoyMapping = XBOX_360) -> types.Joy:
    """The ``Joy`` message a pad in this state sends (LT and RT released)."""
    sign = -1.0 if mapping.x_left_positive else 1.0
    axes = [0.0] * 6
    axes[mapping.left_x] = sign * pad.left_x + 0.0
    axes[mapping.left_y] = pad.left_y
    axes[mapping.right_x] = sign * pad.right_x + 0.0
    axes[2] = axes[5] = 1.0  # joy_node's triggers rest at +1
    buttons = [0] * 11
    for button, index in mapping.buttons:
        if button in pad.buttons:
            buttons[index] = 1
    return types.Joy(
        header=types.Header(stamp=types.stamp(time_ns), frame_id="joy"),
        axes=[a if math.isfinite(a) else 0.0 for a in axes],
        buttons=buttons,
    )
