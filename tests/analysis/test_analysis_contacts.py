"""Contact episodes on recorded sessions whose contacts are known (tests/analysis/scenarios)."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from oimi.analysis.load import load_session
from oimi.analysis.metrics import session_metrics
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.runner import Session
from oimi.scenarios.simulation.humans import PACE
from oimi.scenarios.simulation.world import CONTACT_TOLERANCE_M

SCENARIOS = Path(__file__).resolve().parent / "scenarios"


def _contacts(mcap: Path):
    metrics = session_metrics(load_session(mcap, stream=True))
    return metrics["contacts"], metrics.summary.row(0, named=True)


def test_the_robot_driven_into_a_standing_child_initiates_the_contact(contact_mcaps) -> None:
    """Reversing into a child the front camera cannot see: the supervisor, which works from
    the map, has nothing to act on, so the contact happens and the analysis must show it."""
    contacts, summary = _contacts(contact_mcaps["scripted_collision"])
    assert contacts.height == 1
    (contact,) = contacts.rows(named=True)
    assert contact["human"] == "child"
    assert contact["initiator"] == "robot"
    # 0.95 m of gap at 0.4 m/s from 1.0 s (and a short speed ramp): touching near 3.4-3.6 s
    assert 3_300 <= contact["started_ms"] <= 3_700
    assert contact["robot_speed_mps"] == pytest.approx(0.4, abs=0.02)
    assert contact["person_speed_mps"] == pytest.approx(0.0, abs=0.02)
    assert contact["closing_speed_mps"] == pytest.approx(0.4, abs=0.03)
    assert -0.05 <= contact["min_surface_distance_m"] <= 0.0
    assert summary["robot_initiated_contacts"] == 1
    assert summary["min_surface_distance_m"] <= 0.0


def test_a_child_walking_into_a_standing_robot_initiates_the_contact(contact_mcaps) -> None:
    contacts, summary = _contacts(contact_mcaps["child_walks_into_robot"])
    assert contacts.height == 1
    (contact,) = contacts.rows(named=True)
    assert contact["initiator"] == "person"
    # 0.5 m/s times the child's seeded pace; 2.45 m of gap closed at that speed, but for the
    # last CONTACT_TOLERANCE_M, within which the world already counts a touch; to a tick
    speed = contact["person_speed_mps"]
    assert 0.5 * PACE[0] - 1e-6 <= speed <= 0.5 * PACE[1] + 1e-6
    closed_m = 2.45 - CONTACT_TOLERANCE_M
    assert contact["started_ms"] == pytest.approx(closed_m / speed * 1000, abs=30)
    assert contact["robot_speed_mps"] == pytest.approx(0.0, abs=0.02)
    assert contact["closing_speed_mps"] == pytest.approx(speed, abs=0.02)
    assert summary["robot_initiated_contacts"] == 0
    assert summary["contacts"] == 1


@pytest.mark.parametrize(
    ("name", "passed"),
    [("scripted_collision", [False, False]), ("child_walks_into_robot", [True, True])],
)
def test_oimi_run_checks_contacts_with_the_same_definitions(name: str, passed: list[bool]) -> None:
    result = Session(load_scenario(SCENARIOS / f"{name}.toml")).run()
    assert [v.ok for v in result.verdicts] == passed
    assert result.summary.contact_episodes == 1
    assert result.summary.robot_initiated_contacts == (name == "scripted_collision")


def test_touches_a_moment_apart_are_one_episode_and_zones_use_the_surfaces() -> None:
    from oimi.pipeline.events import BodyState, WorldState
    from oimi.pipeline.proximity import ProximityTracker, zone_of

    robot = BodyState(id="robot", kind="robot", x_m=0.0, y_m=0.0, vx_mps=0.2, radius_m=0.3)

    def state(tick: int, x_m: float) -> WorldState:
        child = BodyState(id="c", kind="child", x_m=x_m, y_m=0.0, vx_mps=-0.1, radius_m=0.2)
        return WorldState(tick=tick, time_ms=tick * 20, robot=robot, humans=(child,))

    tracker = ProximityTracker(tick_ms=20)
    #        apart, touching x3, apart 100 ms (merged), touching, apart 300 ms (ends it)
    gaps = [0.1, 0.0, -0.01, 0.0, 0.05, 0.05, 0.05, 0.05, 0.05, 0.0] + [0.1] * 15 + [0.0]
    for tick, gap in enumerate(gaps):
        tracker.update(state(tick, 0.5 + gap))
    first, second = tracker.finish()
    assert (first.start_ms, first.end_ms, first.min_surface_distance_m) == (20, 200, -0.01)
    assert (second.start_ms, second.end_ms) == (500, 520)  # still touching at the end
    assert first.initiator == "robot"  # 0.2 m/s towards the child, the child 0.1 m/s
    assert first.closing_speed_mps == pytest.approx(0.3)
    assert tracker.zone_ms["c"]["contact"] == 5 * 20  # ticks 1-3, 9 and 25
    assert [zone_of(d) for d in (-0.1, 0.0, 0.3, 0.45, 2.0, 4.0)] == [
        "contact",
        "contact",
        "intimate",
        "personal",
        "social",
        "public",
    ]


def test_a_tracker_without_zones_finds_the_same_distances_and_episodes() -> None:
    """The expectations' tracker counts no time in zones; all else is the analysis's."""
    from oimi.pipeline.proximity import ProximityTracker

    session = Session(load_scenario(SCENARIOS / "child_walks_into_robot.toml"))
    full, lean = ProximityTracker(tick_ms=20), ProximityTracker(tick_ms=20, zones=False)
    for tick in range(session.scenario.ticks):
        session.step(tick)
        state = session.world.state(tick=tick, time_ms=tick * 20)
        full.update(state)
        lean.update(state)
    assert lean.zone_ms == {} and sum(full.zone_ms["child"].values()) == tick * 20 + 20
    assert (lean.closest_m, lean.closest_centres_m) == (full.closest_m, full.closest_centres_m)
    assert lean.finish() == full.finish() != []


@settings(max_examples=300, deadline=None, derandomize=True)
@given(st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from([0.45, 1.2, 3.6, -0.0]))
def test_a_distance_is_in_the_zone_whose_bounds_hold_it(distance_m: float) -> None:
    from oimi.pipeline.proximity import ZONES_M, zone_of

    holding = [
        name
        for name, low, high in ZONES_M
        if (distance_m <= high if name == "contact" else low <= distance_m < high)
    ]
    assert zone_of(distance_m) == (holding[0] if holding else "public")  # NaN: none holds it
