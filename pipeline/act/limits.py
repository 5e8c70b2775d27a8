"""The robot's speed and acceleration limits, the clamp of commanded speeds and the ramp.

A script asking for 10 m/s must not move a robot next to a child at 10 m/s: every
move command goes through :func:`clamp_velocity` before it reaches the body, and
the body's outputs approach their target through :func:`ramp_velocity`.
"""

from __future__ import annotations

import math
from math import copysign, hypot
from typing import Final, NamedTuple

from oimi.pipeline.messages import Message


class RobotLimits(Message):
    """Limits of the robot's body (the scenario's robot section)."""

    max_speed_mps: float = 0.5
    """Largest linear speed, the magnitude of (v_x, v_y), m/s."""
    max_angular_speed_radps: float = 1.5
    """Largest |v_theta|, rad/s."""
    max_accel_mps2: float = 1.0
    """Largest change of the linear velocity vector, m/s²."""
    max_angular_accel_radps2: float = 3.0
    """Largest change of v_theta, rad/s²."""

    def __post_init__(self) -> None:
        for name in self.__struct_fields__:
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"robot limit `{name}` must be a positive number, got {value!r}")


class Velocity(NamedTuple):
    """A body-frame velocity: m/s, m/s, rad/s."""

    v_x: float = 0.0
    v_y: float = 0.0
    v_theta: float = 0.0


STILL = Velocity()
"""Standing still."""

fields: Final = tuple.__new__
"""``fields(Kind, (every field, in order))`` builds a NamedTuple without the ``__new__``
that ``Kind(...)`` runs as Python, compiled too (about 2.5k instructions, this a few
hundred): for those built every tick (``scenarios/simulation/bodies.py``'s ``Motion`` too).
Defaults are not filled in: every field is given."""


class Clamped(NamedTuple):
    """A velocity after :func:`clamp_velocity` and what was clamped (empty: nothing)."""

    velocity: Velocity
    reports: tuple[str, ...]


def fmt(value: float) -> str:
    """A number as clamp reports and notes print it (``10.0``, ``0.3536``)."""
    return repr(round(value, 4) + 0.0)


def clamp_velocity(requested: Velocity, limits: RobotLimits, *, what: str = "move") -> Clamped:
    """``requested`` within ``limits``: (v_x, v_y) scaled to the largest speed keeping its
    direction, |v_theta| cut to the largest angular speed; a non-finite value becomes 0.

    Each clamp gets one human-readable report starting with ``what``.
    """
    reports: list[str] = []
    v_x, v_y, v_theta = requested
    names = ("v_x", "v_y", "v_theta")
    values = [v_x, v_y, v_theta]
    for i, value in enumerate(values):
        if not math.isfinite(value):
            reports.append(f"{what}: {names[i]} {value!r} is not a number, replaced by 0.0")
            values[i] = 0.0
    v_x, v_y, v_theta = values
    in_x, in_y = v_x, v_y
    speed = hypot(v_x, v_y)
    top = limits.max_speed_mps
    if speed > top:
        scale = top / speed
        v_x, v_y = v_x * scale, v_y * scale
        if in_y == 0.0:
            reports.append(
                f"{what}: v_x {fmt(in_x)} m/s > max {fmt(top)} m/s, clamped to {fmt(v_x)}"
            )
        elif in_x == 0.0:
            reports.append(
                f"{what}: v_y {fmt(in_y)} m/s > max {fmt(top)} m/s, clamped to {fmt(v_y)}"
            )
        else:
            reports.append(
                f"{what}: speed |(v_x, v_y)| {fmt(speed)} m/s > max {fmt(top)} m/s, "
                f"scaled to ({fmt(v_x)}, {fmt(v_y)})"
            )
    top_angular = limits.max_angular_speed_radps
    if abs(v_theta) > top_angular:
        clamped = copysign(top_angular, v_theta)
        reports.append(
            f"{what}: v_theta {fmt(v_theta)} rad/s > max {fmt(top_angular)} rad/s, "
            f"clamped to {fmt(clamped)}"
        )
        v_theta = clamped
    return Clamped(Velocity(v_x, v_y, v_theta), tuple(reports))


def capped(v_x: float, v_y: float, top: float) -> tuple[float, float]:
    """(v_x, v_y) scaled down to ``top`` m/s when faster, keeping its direction."""
    speed = hypot(v_x, v_y)
    if speed <= top:
        return (v_x, v_y)
    return (v_x * top / speed, v_y * top / speed)


def ramp_towards(
    c_x: float, c_y: float, t_x: float, t_y: float, step: float
) -> tuple[float, float]:
    """(c_x, c_y) moved towards (t_x, t_y) by at most ``step`` (keeping the direction of
    the change): the target itself when within one step."""
    d_x, d_y = t_x - c_x, t_y - c_y
    change = hypot(d_x, d_y)
    if change <= step:
        return t_x, t_y
    scale = step / change
    return c_x + d_x * scale, c_y + d_y * scale


def ramp_velocity(
    current: Velocity, target: Velocity, limits: RobotLimits, *, dt_ms: int
) -> Velocity:
    """One step of ``dt_ms`` from ``current`` towards ``target`` at the largest accelerations:
    the linear velocity vector changes by at most ``max_accel_mps2 * dt`` (keeping the
    direction of the change), v_theta by at most ``max_angular_accel_radps2 * dt``.
    Reaches the target exactly when it is within one step (and returns ``target`` itself).
    """
    dt_s = dt_ms / 1000.0
    step = limits.max_accel_mps2 * dt_s
    v_x, v_y = ramp_towards(current.v_x, current.v_y, target.v_x, target.v_y, step)
    d_theta = target.v_theta - current.v_theta
    step_theta = limits.max_angular_accel_radps2 * dt_s
    if abs(d_theta) <= step_theta:
        if v_x == target.v_x and v_y == target.v_y:  # (reached: within a step)
            return target
        v_theta = target.v_theta
    else:
        v_theta = current.v_theta + copysign(step_theta, d_theta)
    return fields(Velocity, (v_x, v_y, v_theta))
