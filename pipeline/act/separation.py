"""Speed and separation: the velocity one human's reading allows (``pipeline/act/safety.py``
works out the constraints; these meet them). Outside the stop zone the component towards
the human is capped so that the base, braking its whole velocity, stops closing before the
stop zone; inside it, the velocity may not point at any point of the uncertainty disc (a
cone). No clock, no IO.
"""

from __future__ import annotations

import math
from typing import Final, NamedTuple

from oimi.pipeline.events import SafetyZone


class Constraint(NamedTuple):
    """The limit a human (or an echo kept as one) sets on the robot's velocity."""

    human: str
    surface_m: float
    u_x: float
    u_y: float
    """Unit vector from the robot to the human, body frame."""
    cap_mps: float
    """Largest velocity component along u (outside the stop zone), moving straight at them."""
    sin_cone: float | None
    """Inside the stop zone: v must satisfy v.u <= -sin_cone * |v|."""
    zone: SafetyZone
    lead: float = 0.0
    """``a * dt + walk`` (outside the stop zone: the braking bound's terms)."""
    room: float = 0.0
    """``2 * a * (s - stop)`` (none inside the stop zone)."""
    walk: float = 0.0
    """``human_speed_mps``."""


_TOLERANCE: Final = 1e-12
_ANGLE_TOLERANCE: Final = 1e-9
"""A velocity projected onto the view's edge points along it, give or take rounding."""


def braking_cap(lead: float, room: float, walk: float, across: float = 0.0) -> float:
    """The largest closing speed ``c`` that still brakes before the stop zone, with
    ``across`` m/s across (``lead``, ``room``, ``walk``: :class:`Constraint`'s). The base
    brakes its whole velocity at ``a``: ``s / a`` for a speed ``s``, not ``c / a``, so a
    closing component ``c`` closes ``c * s / (2 a)`` meanwhile while the human walks ``walk
    * s / a``. Bounding ``s`` by ``c + across``: ``c * dt + (c + 2 walk) (c + across) / (2
    a) <= gap`` (an oblique approach once closed 0.015 m/s inside the stop zone: the
    closing part braked only at its share of ``a``)."""
    rest = room - 2 * walk * across
    if not rest > 0.0:  # the walk while braking from across fills the gap (or NaN): none
        return 0.0
    lead += across / 2
    return -lead + math.sqrt(lead * lead + rest)


def closing_cap(c: Constraint, across: float) -> float:
    """The largest velocity component along u with ``across`` m/s across it (outside the
    stop zone): :func:`braking_cap`, and ``cap_mps`` (its value with nothing across, and
    the slow zone's cap)."""
    if across == 0.0:
        return c.cap_mps
    return min(c.cap_mps, braking_cap(c.lead, c.room, c.walk, across))


def allowed_by(c: Constraint, v_x: float, v_y: float) -> tuple[float, float]:
    """The nearest velocity to (v_x, v_y) that meets the constraint (outside the stop zone:
    with what it has across u kept)."""
    along = v_x * c.u_x + v_y * c.u_y
    if c.sin_cone is None:
        if along <= 0.0:
            return v_x, v_y
        cap = closing_cap(c, math.hypot(v_x - along * c.u_x, v_y - along * c.u_y))
        if along <= cap:
            return v_x, v_y
        cut = along - cap
        return v_x - cut * c.u_x, v_y - cut * c.u_y
    if c.sin_cone >= 1.0:  # the robot is inside the human's uncertainty disc
        return 0.0, 0.0
    p_x, p_y = v_x - along * c.u_x, v_y - along * c.u_y
    across = math.hypot(p_x, p_y)
    cos_cone = math.sqrt(1.0 - c.sin_cone**2)
    if along * cos_cone <= -c.sin_cone * across:
        return v_x, v_y
    # project onto the cone's edge: direction (-sin, cos) in the (along, across) plane
    reach = -along * c.sin_cone + across * cos_cone
    if reach <= 0.0 or across == 0.0:
        return 0.0, 0.0
    new_along, new_across = -reach * c.sin_cone, reach * cos_cone
    return (
        new_along * c.u_x + new_across * p_x / across,
        new_along * c.u_y + new_across * p_y / across,
    )


def within_view(v_x: float, v_y: float, half_view: float) -> tuple[float, float]:
    """(v_x, v_y) (body frame) when it points within ``half_view`` rad of straight ahead,
    else its projection onto the nearer edge of that cone (none when it points away)."""
    if half_view >= math.pi or abs(math.atan2(v_y, v_x)) <= half_view + _ANGLE_TOLERANCE:
        return v_x, v_y
    e_x, e_y = math.cos(half_view), math.copysign(math.sin(half_view), v_y)
    along = v_x * e_x + v_y * e_y
    return (along * e_x, along * e_y) if along > 0.0 else (0.0, 0.0)


def satisfied(c: Constraint, v_x: float, v_y: float) -> bool:
    along = v_x * c.u_x + v_y * c.u_y
    if c.sin_cone is None:
        if along <= 0.0:
            return True
        across = math.hypot(v_x - along * c.u_x, v_y - along * c.u_y)
        return along <= closing_cap(c, across) + _TOLERANCE
    return along <= -c.sin_cone * math.hypot(v_x, v_y) + _TOLERANCE
