"""Speed and separation's functions (``pipeline/act/separation.py``): slowing a velocity
until several humans' constraints all hold, and escaping a disc that nearly reaches the
robot."""

from __future__ import annotations

import math

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from oimi.pipeline.act.limits import RobotLimits, Velocity, ramp_velocity
from oimi.pipeline.act.separation import (
    Constraint,
    allowed_by,
    braking_cap,
    followed_meeting,
    meeting,
    satisfied,
    scaled_to_meet,
)
from oimi.pipeline.events import SafetyZone
from supervision import MARGIN_M, RADII_M, TICK_MS, room, seen, supervise

A, WALK, STOP, SLOW_M, SLOW_MPS = 1.0, 1.0, 0.1, 0.5, 0.2


def constraint(surface: float, bearing: float, margin: float) -> Constraint:
    """A human ``surface`` m away (surface to surface) at ``bearing``, as the supervisor
    makes it (its defaults: 1 m/s², 1 m/s, stop 0.1 m, slow 0.5 m at 0.2 m/s)."""
    distance = surface + RADII_M + margin
    u_x, u_y = math.cos(bearing), math.sin(bearing)
    sin_disc = min(margin / distance, 1.0)
    if surface <= STOP:
        return Constraint(
            "h", surface, u_x, u_y, 0.0, sin_disc, SafetyZone.STOP, WALK, A * distance
        )
    lead, room_ = A * TICK_MS / 1000 + WALK, 2 * A * (surface - STOP)
    cap = braking_cap(lead, room_, WALK)
    cap = min(cap, SLOW_MPS) if surface < SLOW_M else cap
    return Constraint(
        "h", surface, u_x, u_y, cap, sin_disc, SafetyZone.SLOW, WALK, A * distance, lead, room_
    )


human = st.builds(
    constraint, st.floats(-0.3, 1.5), st.floats(-math.pi, math.pi), st.floats(0.04, 0.6)
)
speed = st.floats(-0.5, 0.5)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(humans=st.lists(human, min_size=1, max_size=4), v_x=speed, v_y=speed)
def test_a_velocity_is_slowed_to_the_largest_share_that_meets_every_constraint(
    humans, v_x, v_y
) -> None:
    assume(math.hypot(v_x, v_y) > 1e-6)
    s_x, s_y = scaled_to_meet(humans, v_x, v_y)
    assert all(satisfied(c, s_x, s_y) for c in humans)
    share = math.hypot(s_x, s_y) / math.hypot(v_x, v_y)
    if share < 1.0 - 1.5 / 1024:  # a 1/1024 more would break one
        more = share + 1 / 1024
        assert not all(satisfied(c, v_x * more, v_y * more) for c in humans)
    assert s_x * v_y == pytest.approx(s_y * v_x, abs=1e-12)  # its direction kept


@settings(max_examples=1000, deadline=None, derandomize=True)
@given(
    humans=st.lists(human, min_size=1, max_size=3),
    v_x=speed,
    v_y=speed,
    m_x=speed,
    m_y=speed,
)
def test_the_base_lagging_its_command_still_meets_every_constraint_when_it_can(
    humans, v_x, v_y, m_x, m_y
) -> None:
    """The base moves at (m_x, m_y) and changes by a*dt a tick at most. When the velocity
    the passes make of the base's is within a tick's reach, or braking straight meets every
    constraint after the tick, the command let through has an outcome that meets them all
    (an adversarial review found braking straight meeting them where the command let
    through did not, 116 times in 42,720). Otherwise it is that velocity or a stand,
    whichever closes more slowly on the nearest constraint broken, or the one asked for
    when it turns the base the same way; never faster than the request or the base."""

    def followed(c_x: float, c_y: float) -> tuple[float, float]:
        after = ramp_velocity(Velocity(m_x, m_y), Velocity(c_x, c_y), RobotLimits(), dt_ms=TICK_MS)
        return after.v_x, after.v_y

    v_x, v_y, _ = meeting(humans, v_x, v_y, math.pi)  # what the passes let through
    step = A * TICK_MS / 1000
    r_x, r_y, broken = followed_meeting(humans, v_x, v_y, math.pi, (m_x, m_y), step, math.inf)
    o_x, o_y = followed(r_x, r_y)
    meets = all(satisfied(c, o_x, o_y) for c in humans)
    b_x, b_y, _ = meeting(humans, m_x, m_y, math.pi)
    if math.hypot(b_x - m_x, b_y - m_y) <= step:
        assert meets
    if all(satisfied(c, *followed(0.0, 0.0)) for c in humans):
        assert meets
    if broken is None:
        assert (r_x, r_y) == (v_x, v_y)
    elif not meets:
        assert (r_x, r_y) in ((b_x, b_y), (0.0, 0.0))
        f_x, f_y = followed(v_x, v_y)
        assert not all(satisfied(c, f_x, f_y) for c in humans)
        closing = {(r_x, r_y): o_x * broken.u_x + o_y * broken.u_y}
        for start in ((b_x, b_y), (0.0, 0.0)):
            s_x, s_y = followed(*start)
            assert closing[r_x, r_y] <= s_x * broken.u_x + s_y * broken.u_y
    assert math.hypot(r_x, r_y) <= max(math.hypot(v_x, v_y), math.hypot(m_x, m_y)) + 1e-12


def test_two_children_the_passes_cannot_settle_slow_the_robot_rather_than_stop_it() -> None:
    """Two children 0.3 and 0.4 m away, either side: three passes of bending for one and
    the other did not settle (the robot stopped, on 5.7 % of the ticks with two or three
    children near, 43 % of them for the passes alone; found by an adversarial review)."""
    children = (seen(0.904, 2.842, ident="a"), seen(0.971, -0.527, ident="b"))
    verdict, _ = supervise(Velocity(0.416, 0.422, 0.0), room(*children))
    v_x, v_y, _ = verdict.velocity
    assert 0.1 < math.hypot(v_x, v_y) < 0.3
    for child in children:
        c = constraint(child.positionrho - RADII_M - MARGIN_M, child.positiontheta, MARGIN_M)
        assert satisfied(c, v_x, v_y)


def test_straight_away_from_a_disc_that_nearly_reaches_the_robot_is_as_fast_as_it_may() -> None:
    """A child's disc 0.52 m wide around a point 0.6 m behind (a stale echo): straight
    away is safe up to the speed at which the disc, grown by the child's walk while the
    base brakes, would reach past the robot's side: ``walk * s - s**2 / 2 = (1 - sin) a d``
    (the halfway cone's speed, 0.04 m/s, once made an escape take 2.5 s for 10 cm)."""
    margin, distance = 0.52, 0.6
    behind = constraint(distance - RADII_M - margin, math.pi, margin)
    v_x, v_y = allowed_by(behind, 0.5, 0.0)
    fastest = WALK - math.sqrt(WALK**2 - 2 * (1 - margin / distance) * A * distance)
    assert (v_x, v_y) == pytest.approx((fastest, 0.0))
    assert fastest > 0.08
