"""The supervisor makes no constraint for a human too far to limit the velocity asked for
(``SafetySupervisor._clear_m``): skipping them must change no verdict."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st
from oimi.pipeline.act.limits import Velocity
from oimi.pipeline.act.safety import SafetySupervisor
from supervision import CONFIG, LIMITS, TICK_MS, room, seen, supervise


class EveryHuman(SafetySupervisor):
    """A supervisor that makes every human's constraint, however far."""

    def _clear_m(self, speed: float) -> float:
        return math.inf


speed = st.floats(-0.5, 0.5)
human = st.tuples(st.floats(0.6, 4.0), st.floats(-math.pi, math.pi), st.integers(0, 700))


@settings(max_examples=300, deadline=None, derandomize=True)
@given(v_x=speed, v_y=speed, humans=st.lists(human, min_size=1, max_size=3), now=st.integers(0, 3))
def test_skipping_the_far_humans_changes_no_verdict(v_x, v_y, humans, now) -> None:
    """Humans at 0.6 to 4 m (centre), readings up to 0.7 s old, one to three, ticks
    apart (the protective stop's hold carries over): the same verdict each tick."""
    asked = Velocity(v_x, v_y, 0.3)
    skipping = SafetySupervisor(CONFIG, LIMITS, tick_ms=TICK_MS)
    every = EveryHuman(CONFIG, LIMITS, tick_ms=TICK_MS)
    world = room(
        *(seen(rho, theta, at_ms=-age, ident=f"h{i}") for i, (rho, theta, age) in enumerate(humans))
    )
    for tick in range(now + 1):
        now_ms = tick * TICK_MS
        assert supervise(asked, world, now_ms=now_ms, supervisor=skipping) == supervise(
            asked, world, now_ms=now_ms, supervisor=every
        )


def test_a_far_human_is_not_made_a_constraint() -> None:
    """So that the test above compares two ways: the skip happens at these distances."""
    supervisor = SafetySupervisor(CONFIG, LIMITS, tick_ms=TICK_MS)
    clear = supervisor._clear_m(0.5)
    assert 1.0 < clear < 2.0  # 0.1 + 0.01 + 2.5 * 0.5 = 1.36 m
    assert supervisor._clear_m(0.0) == CONFIG.filled().slow_distance_m
