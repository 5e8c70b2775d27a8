"""Speed and separation: the velocity one human's reading allows (``pipeline/act/safety.py``
works out the constraints; these meet them). The base brakes its whole velocity, along a
straight line, in ``speed / a``; meanwhile the human may walk ``human_speed_mps`` anywhere.
So a velocity is allowed when the base stops before the human can reach the stop zone
(closing on them: at most what still brakes in time), or when it points away from every
point the human may reach meanwhile (a cone around "away" that widens with the speed).
Inside the stop zone only the cone is left. No clock, no IO.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from math import asin, atan2, copysign, cos, hypot, sin, sqrt
from typing import Final, NamedTuple

from oimi.pipeline.act.limits import capped, ramp_towards
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
    sin_disc: float
    """The uncertainty disc's radius over its centre's distance (1.0: the robot is in it)."""
    zone: SafetyZone
    """``STOP``: inside the stop zone (only the cone is left); else ``SLOW``."""
    walk: float
    """``human_speed_mps``."""
    reach: float
    """``a * d``: the base's braking rate times the disc centre's distance."""
    lead: float = 0.0
    """``a * dt + walk`` (outside the stop zone: the braking bound's terms)."""
    room: float = 0.0
    """``2 * a * (s - stop)`` (none inside the stop zone)."""


_STOP: Final = SafetyZone.STOP
"""(A module name: a member read through its enum class takes a slow path, at every test.)"""
_TOLERANCE: Final = 1e-12
_SAME: Final = 1e-12
"""Two velocities this close (m/s, each component) are the same, give or take rounding."""
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
    return -lead + sqrt(lead * lead + rest)


def stopping_way(speed: float, dt: float, a: float) -> float:
    """How far a base at ``speed`` goes in a tick ``dt`` and then braking at ``a``."""
    return speed * (dt + speed / (2 * a))


def clear_gap(speed: float, dt: float, walk: float, a: float) -> float:
    """The gap (``s - stop``) from which :func:`braking_cap` allows any closing part up to
    ``speed`` with as much again across (``c + across <= 2 speed``), and a base at
    ``speed`` stands in time (:func:`stops_in_time`): no velocity that fast can break it."""
    return speed * dt + (speed + 2 * walk) * speed / a


def closing_cap(c: Constraint, across: float) -> float:
    """The largest velocity component along u with ``across`` m/s across it (outside the
    stop zone): :func:`braking_cap`, and ``cap_mps`` (its value with nothing across, and
    the slow zone's cap)."""
    if across == 0.0:
        return c.cap_mps
    return min(c.cap_mps, braking_cap(c.lead, c.room, c.walk, across))


def stops_in_time(c: Constraint, speed: float) -> bool:
    """Whether the base, braking from ``speed``, stands before the human can walk into
    the stop zone (outside it, not closing on them): ``walk * speed / a <= s - stop``."""
    return 2 * c.walk * speed <= c.room + _TOLERANCE


def cone_sine(c: Constraint, speed: float) -> float:
    """The sine of the cone around "away" for a velocity of ``speed``. The base brakes from
    it in ``t = speed / a``, moving ``speed * t / 2`` away while the human may walk ``walk *
    t`` towards where it goes: the disc grows by the difference (at most ``walk**2 / 2a``:
    beyond ``walk`` the base outruns them). With the disc as it stood, a child who walked
    round the braking robot had it close on them at 0.0003 m/s inside the stop zone."""
    if c.sin_disc >= 1.0:  # the robot is inside the disc (its distance may be none)
        return c.sin_disc
    s = min(speed, c.walk)
    return c.sin_disc + (c.walk * s - s * s / 2) / c.reach


def cone_speed(c: Constraint, sine: float) -> float:
    """The inverse of :func:`cone_sine`: the fastest speed whose cone's sine is at most
    ``sine`` (0.0 when even a stand's is wider; ``inf`` when no speed's reaches it)."""
    grown = (sine - c.sin_disc) * c.reach  # walk * s - s**2 / 2 may reach this
    if grown <= 0.0:
        return 0.0
    rest = c.walk * c.walk - 2 * grown
    return c.walk - sqrt(rest) if rest > 0.0 else math.inf


def allowed_by(c: Constraint, v_x: float, v_y: float) -> tuple[float, float]:
    """The nearest velocity to (v_x, v_y) that meets the constraint (closing on them: with
    what it has across u kept; else slowed to stop in time or bent into the cone, whichever
    is nearer)."""
    along = v_x * c.u_x + v_y * c.u_y
    if c.zone is _STOP:
        return _into_cone(c, v_x, v_y, along)
    if along > 0.0:
        cap = closing_cap(c, hypot(v_x - along * c.u_x, v_y - along * c.u_y))
        if along <= cap:
            return v_x, v_y
        cut = along - cap
        v_x, v_y = v_x - cut * c.u_x, v_y - cut * c.u_y
        if cap > 0.0:  # closing still: it stops in time
            return v_x, v_y
        along = 0.0  # across alone: it must stop in time or point away
    speed = hypot(v_x, v_y)
    if stops_in_time(c, speed):
        return v_x, v_y
    b_x, b_y = bent = _into_cone(c, v_x, v_y, along)
    scale = c.room / (2 * c.walk * speed)  # the speed that stops in time
    s_x, s_y = slowed = v_x * scale, v_y * scale
    if (b_x - v_x) ** 2 + (b_y - v_y) ** 2 <= (s_x - v_x) ** 2 + (s_y - v_y) ** 2:
        return bent
    return slowed


def _into_cone(c: Constraint, v_x: float, v_y: float, along: float) -> tuple[float, float]:
    """The nearest velocity to (v_x, v_y) inside the cone of its speed (projected onto its
    edge). One too fast for any cone is slowed: its direction kept, to the fastest speed
    whose cone holds it, or to the speed whose cone is halfway from a stand's to a closed
    one and projected, whichever is nearer."""
    if c.sin_disc >= 1.0:  # the robot is inside the human's uncertainty disc
        return 0.0, 0.0
    speed = hypot(v_x, v_y)
    sin_cone = cone_sine(c, speed)
    if sin_cone < 1.0:
        return _onto_cone(c, v_x, v_y, along, sin_cone)
    scale = min(cone_speed(c, -along / speed), speed) / speed  # (speed > 0: sin_disc < 1)
    kept = v_x * scale, v_y * scale
    halfway = (1.0 + c.sin_disc) / 2
    slower = min(cone_speed(c, halfway), speed) / speed
    bent = _onto_cone(c, v_x * slower, v_y * slower, along * slower, halfway)
    if (kept[0] - v_x) ** 2 + (kept[1] - v_y) ** 2 <= (bent[0] - v_x) ** 2 + (bent[1] - v_y) ** 2:
        return kept
    return bent


def _onto_cone(
    c: Constraint, v_x: float, v_y: float, along: float, sin_cone: float
) -> tuple[float, float]:
    """(v_x, v_y) when it points inside the cone of sine ``sin_cone``, else its projection
    onto the cone's nearer edge (none when it points at the human)."""
    p_x, p_y = v_x - along * c.u_x, v_y - along * c.u_y
    across = hypot(p_x, p_y)
    cos_cone = sqrt(1.0 - sin_cone**2)
    if along * cos_cone <= -sin_cone * across:
        return v_x, v_y
    # project onto the cone's edge: direction (-sin, cos) in the (along, across) plane
    length = -along * sin_cone + across * cos_cone
    if length <= 0.0 or across == 0.0:
        return 0.0, 0.0
    new_along, new_across = -length * sin_cone, length * cos_cone
    return (
        new_along * c.u_x + new_across * p_x / across,
        new_along * c.u_y + new_across * p_y / across,
    )


def scaled_to_meet(
    constraints: list[Constraint],
    v_x: float,
    v_y: float,
    followed: Callable[[float, float], tuple[float, float]] | None = None,
    start: tuple[float, float] = (0.0, 0.0),
) -> tuple[float, float]:
    """The velocity nearest (v_x, v_y) on the way from ``start`` (a stand unless told) that
    meets every constraint (to 1/1024 of the way): each is easier the slower the velocity
    (the braking bound and standing in time by its speed, the cone narrower), and a stand
    meets all. Given ``followed`` (the velocity the base takes for a command), the one whose
    outcome meets them (``start``'s must)."""
    s_x, s_y = start
    d_x, d_y = v_x - s_x, v_y - s_y
    low, high = 0.0, 1.0
    for _ in range(10):
        share = (low + high) / 2
        o_x, o_y = s_x + d_x * share, s_y + d_y * share
        if followed is not None:
            o_x, o_y = followed(o_x, o_y)
        if all(satisfied(c, o_x, o_y) for c in constraints):
            low = share
        else:
            high = share
    return s_x + d_x * low, s_y + d_y * low


def meeting(
    constraints: list[Constraint], v_x: float, v_y: float, half_view: float
) -> tuple[float, float, Constraint | None]:
    """The velocity nearest (v_x, v_y) that meets every constraint and stays within
    ``half_view`` of straight ahead, and the nearest constraint that changed it."""
    binding: Constraint | None = None
    for _ in range(3):  # a few passes settle several humans; otherwise slow down
        for constraint in constraints:
            limited = allowed_by(constraint, v_x, v_y)
            if limited != (v_x, v_y):
                v_x, v_y = limited
                binding = nearer(binding, constraint)
        v_x, v_y = within_view(v_x, v_y, half_view)
        if all(satisfied(c, v_x, v_y) for c in constraints):
            break
    else:  # as fast as meets them all, direction kept (stopped, a child once waited)
        v_x, v_y = scaled_to_meet(constraints, v_x, v_y)
    return v_x, v_y, binding


def _surface(constraint: Constraint) -> float:
    return constraint.surface_m


def followed_meeting(
    constraints: list[Constraint],
    v_x: float,
    v_y: float,
    half_view: float,
    rolling: tuple[float, float],
    step: float,
    top: float,
) -> tuple[float, float, Constraint | None]:
    """For (v_x, v_y), what :func:`meeting` let through: itself when the velocity the base
    takes for it in a tick (from ``rolling``, its velocity now, changing by ``step`` at
    most: :func:`~oimi.pipeline.act.limits.ramp_towards`) meets every constraint. Else,
    with the nearest constraint that outcome broke, the command nearest (v_x, v_y) on the
    way to it from a start whose outcome meets them all: what :func:`meeting` makes of
    ``rolling`` capped at ``top`` (as the request was), or else a stand (braking straight).
    When neither start's outcome meets them, the one whose outcome closes more slowly on
    that constraint (the base turns towards it as fast as it can), unless (v_x, v_y) turns
    the base the same way (a slower drive straight on: nothing to change, no limit)."""
    m_x, m_y = rolling

    def followed(c_x: float, c_y: float) -> tuple[float, float]:
        return ramp_towards(m_x, m_y, c_x, c_y, step)

    f_x, f_y = followed(v_x, v_y)
    if f_x == v_x and f_y == v_y:  # within a tick's reach: (v_x, v_y) met them (most ticks)
        return v_x, v_y, None
    failing = [c for c in constraints if not satisfied(c, f_x, f_y)]
    if not failing:
        return v_x, v_y, None
    nearest = min(failing, key=_surface)
    b_x, b_y, _ = meeting(constraints, *capped(m_x, m_y, top), half_view)
    starts = ((b_x, b_y), (0.0, 0.0))
    outcomes = [followed(*start) for start in starts]
    for start, (o_x, o_y) in zip(starts, outcomes, strict=True):
        if all(satisfied(c, o_x, o_y) for c in constraints):
            v_x, v_y = scaled_to_meet(constraints, v_x, v_y, followed, start)
            return v_x, v_y, nearest
    (o_x, o_y), (s_x, s_y) = outcomes
    if s_x * nearest.u_x + s_y * nearest.u_y < o_x * nearest.u_x + o_y * nearest.u_y:
        b_x, b_y, o_x, o_y = 0.0, 0.0, s_x, s_y  # braking straight closes more slowly
    if abs(o_x - f_x) <= _SAME and abs(o_y - f_y) <= _SAME:
        return v_x, v_y, None
    return b_x, b_y, nearest


def nearer(a: Constraint | None, b: Constraint | None) -> Constraint | None:
    """The nearer of two constraints (either may be none)."""
    if a is None or (b is not None and b.surface_m < a.surface_m):
        return b
    return a


def body_view(half_view: float, reach_m: float, beyond_m: float) -> float:
    """The half angle (rad, from straight ahead) of the directions in which a robot may
    drive, its view ``half_view`` rad either side of straight ahead, without coming within
    ``reach_m`` (centre to centre) of a body centred outside that view more than
    ``beyond_m`` from it (``reach_m <= beyond_m``). A camera sees a body's centre, not its
    disc: driving straight at ``b`` rad inside an edge, the robot's centre passes a point
    just outside it, ``D`` away, at ``D sin b``; that is ``reach_m`` or more for every ``D``
    from ``beyond_m`` on when ``sin b >= reach_m / beyond_m`` (and a point farther round
    is passed farther off, or lies behind). A body nearer than ``beyond_m`` beside the
    robot no straight drive can be sure to miss (right beside it, none can). Negative: no
    direction (a view too narrow); pi: a view all round (``half_view >= pi``)."""
    if half_view >= math.pi:
        return math.pi
    return half_view - asin(min(reach_m / beyond_m, 1.0))


def sighted_range_m(
    reach_m: float, top_mps: float, walk_mps: float, frame_s: float, dt_s: float, a: float
) -> float:
    """The least range (m, from the robot's centre) within which a camera must report a person's
    centre for a robot driving inside its view, the sonar ring down, to be at rest before a
    child there, walking at it at ``walk_mps``, can reach the stop zone: beyond the range
    nothing reports them. Their centre comes within the range while the robot drives at up to
    ``top_mps``; a frame taken since reports them within ``frame_s`` (a camera whose latest
    frame is older counts as offline: ``max_frame_age_ms``; frames that may miss them add
    ``camera_miss_ms``), and the supervisor acts on it in that tick; meanwhile both close in at
    their speeds, then the robot goes a tick and brakes at ``a`` (:func:`stopping_way`) while
    the child walks on. ``reach_m``: the stop zone's edge, centre to centre (both radii, the
    sensing error, ``stop_distance_m``). 2.075 m with the defaults (0.67 + 0.25 + 0.135 + 1.02);
    a camera reaching less leaves no direction while the ring is down. (Taking the child for
    standing, 1.055 m, let a robot at 0.5 m/s still drive at full speed when a child walking at
    1 m/s reached its stop zone.)"""
    waited_s = frame_s + dt_s + top_mps / a  # the frame's wait, the tick, the braking
    return reach_m + top_mps * frame_s + stopping_way(top_mps, dt_s, a) + walk_mps * waited_s


def within_view(v_x: float, v_y: float, half_view: float) -> tuple[float, float]:
    """(v_x, v_y) (body frame) when it points within ``half_view`` rad of straight ahead,
    else its projection onto the nearer edge of that cone (none when it points away, or
    when ``half_view`` is negative: no direction)."""
    if half_view >= math.pi or abs(atan2(v_y, v_x)) <= half_view + _ANGLE_TOLERANCE:
        return v_x, v_y
    if half_view < 0.0:
        return 0.0, 0.0
    e_x, e_y = cos(half_view), copysign(sin(half_view), v_y)
    along = v_x * e_x + v_y * e_y
    return (along * e_x, along * e_y) if along > 0.0 else (0.0, 0.0)


def satisfied(c: Constraint, v_x: float, v_y: float) -> bool:
    """Whether (v_x, v_y) meets the constraint (what :func:`allowed_by` returns does)."""
    along = v_x * c.u_x + v_y * c.u_y
    if c.zone is not _STOP and along > 0.0:
        across = hypot(v_x - along * c.u_x, v_y - along * c.u_y)
        return along <= closing_cap(c, across) + _TOLERANCE
    speed = hypot(v_x, v_y)
    if c.zone is not _STOP and stops_in_time(c, speed):
        return True
    return along <= -cone_sine(c, speed) * speed + _TOLERANCE
