"""Rule codes of the rule library, by name (the ``rulecode`` of alfa/omega messages).

The rule library (``pipeline.think.library``) registers its rule classes under these
codes; generators name them here instead of writing bare numbers.
"""

from __future__ import annotations

import enum


class RuleCode(enum.IntEnum):
    """The rule classes a script may load, unload, hold or recover."""

    KICK_STARTER = 0
    """While idle, welcomes a child who comes in front (the thesis's ``kick_starter``)."""
    CHILD_TOO_CLOSE = 1
    """Safety: stops forward motion when a child is closer than the safety distance."""
    CHILD_LEFT = 2
    """Notices a child leaving the scene."""
    TOUCH_REWARD = 3
    """Answers a caress with light and sound."""
    ATTENTION_LOST = 4
    """Notices a child's attention dropping."""
    BATTERY_LOW = 5
    """Ends the activity when the battery runs low."""
    JOYSTICK_NOTE = 6
    """Notes the operator's joystick taking over."""
    OBSTACLE_TOO_CLOSE = 7
    """Safety: stops motion when furniture is closer than the safety distance."""
    HUG_REWARD = 8
    """Answers a hug with a warm glow."""
    TOY_NEARBY = 9
    """Notes in the map when the target toy is within reach."""
    SENSORS_BLIND = 10
    """Safety: stops motion while the camera is offline (the robot cannot see children)."""


KICK_STARTER = RuleCode.KICK_STARTER
CHILD_TOO_CLOSE = RuleCode.CHILD_TOO_CLOSE
CHILD_LEFT = RuleCode.CHILD_LEFT
TOUCH_REWARD = RuleCode.TOUCH_REWARD
ATTENTION_LOST = RuleCode.ATTENTION_LOST
BATTERY_LOW = RuleCode.BATTERY_LOW
JOYSTICK_NOTE = RuleCode.JOYSTICK_NOTE
OBSTACLE_TOO_CLOSE = RuleCode.OBSTACLE_TOO_CLOSE
HUG_REWARD = RuleCode.HUG_REWARD
TOY_NEARBY = RuleCode.TOY_NEARBY
SENSORS_BLIND = RuleCode.SENSORS_BLIND
