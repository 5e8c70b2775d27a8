"""The dead reckoning's slip: a measured speed that the reckoned velocity does not explain."""

from __future__ import annotations

import math

import msgspec
import pytest
from oimi.pipeline.act.limits import Velocity
from oimi.pipeline.act.reckoning import DeadReckoning, Slip
from oimi.pipeline.act.safety import SafetySupervisor
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.messages import RobotStatus, Sonar, SpeedStatus, WorldMap

from tests.pipeline.act.supervision import LIMITS, TICK_MS, room, seen, supervise

ERROR = 0.05
TICKS_PER_S = 1000 // TICK_MS


def report(at_ms: int, forward: float = 0.0, left: float = 0.0, turn: float = 0.0) -> SpeedStatus:
    return SpeedStatus(
        xspeed=forward, yspeed=left, thetaspeed=turn, duration=1000, startingtime=at_ms
    )


def driven(reports: dict[int, SpeedStatus], velocity: Velocity, seconds: int) -> DeadReckoning:
    """A reckoning driven at ``velocity`` for ``seconds``, told ``reports`` by tick."""
    reckoning = DeadReckoning(LIMITS, tick_ms=TICK_MS, kept_ms=500, error_mps=ERROR, radius_m=0.3)
    for tick in range(seconds * TICKS_PER_S + 1):
        reckoning.mark(tick * TICK_MS)
        if tick in reports:
            reckoning.measured(reports[tick])
        reckoning.advance(velocity)
    return reckoning


def every_second(seconds: int, **measured: float) -> dict[int, SpeedStatus]:
    return {s * TICKS_PER_S: report(s * 1000, **measured) for s in range(seconds + 1)}


def test_a_measured_speed_the_reckoning_explains_is_no_slip() -> None:
    """Driving forward at 0.2 m/s, told 0.2 m/s each second (or 0.2 within the error):
    nothing slipped."""
    for measured in (0.2, 0.2 + 0.9 * ERROR, 0.2 - 0.9 * ERROR):
        reports = every_second(8, forward=measured)
        reports[0] = report(0)  # standing at the start
        reckoning = driven(reports, Velocity(0.2, 0.0, 0.0), 8)
        assert reckoning.slip == Slip()


def test_a_blocked_base_slips_by_the_speed_it_did_not_make() -> None:
    """Pushed into a table at 0.2 m/s for 8 s, the base stands (told 0 each second): the
    reckoning took it 1.6 m on, and each report counts 0.2 - 0.05 m/s for its second."""
    reckoning = driven(every_second(8), Velocity(0.2, 0.0, 0.0), 8)
    assert reckoning.pose[0] == pytest.approx(1.58, abs=0.01)
    assert reckoning.slip.distance_m == pytest.approx(8 * (0.2 - ERROR))
    assert reckoning.slip.heading_rad == 0.0
    assert reckoning.slip_at(3500).distance_m == pytest.approx(3 * (0.2 - ERROR))
    assert reckoning.slip_at(-1) == Slip()  # before every report: all of it counts since


def test_a_blocked_turn_slips_by_the_heading_it_did_not_make() -> None:
    """Spinning at 1 rad/s told 0: the rim's error (0.05 m/s at 0.3 m) is no slip, the rest
    is."""
    reckoning = driven(every_second(3), Velocity(0.0, 0.0, 1.0), 3)
    assert reckoning.slip.heading_rad == pytest.approx(3 * (1.0 - ERROR / 0.3))
    assert reckoning.slip.distance_m == 0.0


def test_a_report_seen_again_or_older_counts_once() -> None:
    reckoning = DeadReckoning(LIMITS, tick_ms=TICK_MS, kept_ms=500, error_mps=ERROR, radius_m=0.3)
    reckoning.mark(0)
    reckoning.measured(report(0, forward=1.0))
    for at_ms in (1000, 1000, 400):
        reckoning.mark(at_ms)
        reckoning.measured(report(at_ms, forward=1.0))
    assert reckoning.slip.distance_m == pytest.approx(1.0 - ERROR)


def test_a_report_that_cannot_be_read_loses_the_reckoning() -> None:
    reckoning = DeadReckoning(LIMITS, tick_ms=TICK_MS, kept_ms=500, error_mps=ERROR, radius_m=0.3)
    reckoning.mark(0)
    reckoning.measured(report(0))
    reckoning.mark(1000)
    reckoning.measured(report(1000, forward=math.nan))
    assert reckoning.slip.distance_m == math.inf


def _pushed(
    seconds: int, measured: float, *, ring: bool = False
) -> tuple[SafetySupervisor, WorldMap]:
    """A child seen once, 1 m to the left (then never again: stale); the robot driven 0.2
    m/s forward for ``seconds``, its speed measured as ``measured`` each second; a sonar
    ring on and scanning (that sees no echo) if ``ring``."""
    supervisor = SafetySupervisor(SafetyConfig(robot_radius_m=0.3), LIMITS, tick_ms=TICK_MS)
    child = seen(1.0, math.pi / 2)
    sonars = [Sonar(id="ring", isonline=True)] if ring else []
    for tick in range(seconds * TICKS_PER_S + 1):
        now = tick * TICK_MS
        status = RobotStatus(speed=[report(now // 1000 * 1000, forward=measured)])
        world_map = msgspec.structs.replace(room(child), robotstatus=status, sonars=sonars)
        supervise(Velocity(0.2, 0.0, 0.0), world_map, now_ms=now, supervisor=supervisor)
    return supervisor, world_map


def test_a_base_pushed_against_furniture_keeps_off_a_child_it_no_longer_sees() -> None:
    """8 s against a table: the reckoning puts the child 1.6 m behind, but the measured
    speed (0) showed the slip, so driving left towards where the child may still be is
    stopped; told the speed it reckoned, the same drive is free (the child far behind)."""
    now = 8 * 1000
    for measured, free in ((0.0, False), (0.2, True)):
        supervisor, world_map = _pushed(8, measured)
        verdict, _ = supervise(
            Velocity(0.0, 0.2, 0.0), world_map, now_ms=now, supervisor=supervisor
        )
        assert (verdict.velocity.v_y == pytest.approx(0.2)) is free, measured
        if not free:
            assert verdict.velocity.v_y == pytest.approx(0.0, abs=1e-9)


def test_with_the_ring_working_slip_widens_nothing() -> None:
    """The same push with a working ring, which sees where the bodies are (here: no echo,
    nobody near): the child's stale reading keeps its margin (grown by every push, a
    reading the camera lost long ago froze the robot in the busy playroom)."""
    supervisor, world_map = _pushed(8, 0.0, ring=True)
    verdict, _ = supervise(Velocity(0.0, 0.2, 0.0), world_map, now_ms=8000, supervisor=supervisor)
    assert verdict.velocity.v_y == pytest.approx(0.2)
