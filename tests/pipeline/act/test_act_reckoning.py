"""The dead reckoning's slip: what the robot's measured speed says it drove, against what
was reckoned."""

from __future__ import annotations

import itertools
import math

import msgspec
import pytest
from oimi.pipeline.act.limits import Velocity
from oimi.pipeline.act.reckoning import LOST_M, DeadReckoning, Slip
from oimi.pipeline.act.safety import SafetySupervisor
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.messages import RobotStatus, Sonar, SpeedStatus, WorldMap

from tests.pipeline.act.supervision import LIMITS, TICK_MS, echo, room, seen, supervise

ERROR = 0.05
TICKS_PER_S = 1000 // TICK_MS


def report(end_ms: int, forward: float = 0.0, turn: float = 0.0, lasted_ms: int = 1000):
    """A speed report: the mean velocity over the ``lasted_ms`` up to ``end_ms``."""
    start = max(end_ms - lasted_ms, 0)
    return SpeedStatus(
        xspeed=forward, yspeed=0.0, thetaspeed=turn, duration=end_ms - start, startingtime=start
    )


def reckoning(push_mps: float = 0.0) -> DeadReckoning:
    """A reckoning (by default of a base no one can push: the push bound apart)."""
    return DeadReckoning(LIMITS, tick_ms=TICK_MS, kept_ms=2000, error=ERROR, push_mps=push_mps)


def driven(velocities, reports: dict[int, SpeedStatus], push_mps: float = 0.0) -> DeadReckoning:
    """A reckoning driven at ``velocities[tick]``, told ``reports`` by tick."""
    reckoned = reckoning(push_mps)
    for tick, velocity in enumerate(velocities):
        reckoned.mark(tick * TICK_MS)
        if tick in reports:
            reckoned.measured([reports[tick]], tick * TICK_MS)
        reckoned.advance(velocity)
    return reckoned


def every_second(seconds: int, mean_mps=lambda second: 0.0) -> dict[int, SpeedStatus]:
    """A report at each whole second, of the mean speed over the second before it."""
    return {s * TICKS_PER_S: report(s * 1000, mean_mps(s)) for s in range(seconds + 1)}


FORWARD = Velocity(0.2, 0.0, 0.0)


def reckoned_means(velocities) -> list[float]:
    """The mean forward speed the reckoning makes over each whole second, by its end (the
    first: 0)."""
    free, went = reckoning(), [0.0]
    for tick, velocity in enumerate(velocities, 1):
        free.advance(velocity)
        if tick % TICKS_PER_S == 0:
            went.append(free.pose[0])  # straight on: x is the distance
    return [0.0] + [b - a for a, b in itertools.pairwise(went)]


def test_a_measured_speed_the_reckoning_explains_slips_by_its_error_alone() -> None:
    """Driving forward at 0.2 m/s for 8 s, told the mean speeds the reckoning made: it may
    have slipped by the measurement's error (5 % of what was measured), no more; told 0.02
    m/s more or less each second, by that too (an allowance once hid slow pushes); nothing
    is unchecked once the last report covers the drive but the braking after it."""
    drive = [FORWARD] * (8 * TICKS_PER_S)
    made = reckoned_means(drive)
    assert made[1] < 0.2 == pytest.approx(made[2])  # the first second ramps up
    for off in (0.0, 0.02, -0.02):
        means = every_second(8, lambda s, e=off: made[s] + e if s else 0.0)
        reckoned = driven([*drive, Velocity()], means)
        measured = sum(made[1:9]) + 8 * off
        assert reckoned.slip.distance_m == pytest.approx(8 * abs(off) + ERROR * measured)
        assert reckoned.slip.heading_rad == 0.0
        later = reckoned.placed(8000)
        rolled = reckoned.drift(later).distance_m  # braking after the last
        assert 0.0 < rolled < 0.2**2 / 2 / LIMITS.max_accel_mps2 + 1e-9


def test_a_blocked_base_slips_by_the_distance_it_did_not_go() -> None:
    """Pushed into a table at 0.2 m/s for 8 s, the base stands (told 0): the reckoning took
    it 1.6 m on, and each report counts that second's reckoned distance."""
    reckoned = driven([FORWARD] * (8 * TICKS_PER_S + 1), every_second(8))
    assert reckoned.pose[0] == pytest.approx(1.58, abs=0.01)
    assert reckoned.slip.distance_m == pytest.approx(1.58, abs=0.01)
    assert reckoned.slip.heading_rad == 0.0
    since_3_5 = reckoned.drift(reckoned.placed(3500))
    assert since_3_5.distance_m == pytest.approx(5 * 0.2, abs=0.01)  # seconds 4-8


def test_a_slow_push_counts_whole() -> None:
    """A child leaning on the standing robot, moving it at 0.04 m/s for 30 s (told each
    second): all of it, and the measurement's error on it (below the error, it once
    counted nothing: 1.3 m of lean, and the robot drove into the child it leant it
    towards; found by an adversarial review)."""
    leant = driven([Velocity()] * (30 * TICKS_PER_S + 1), every_second(30, lambda s: 0.04))
    assert leant.slip.distance_m == pytest.approx(30 * 0.04 * (1 + ERROR))


def test_a_report_older_than_the_states_kept_loses_the_reckoning() -> None:
    """The reckoning keeps 2 s of states here: a report of the 3 s before cannot be told
    from what was driven, so every earlier reading is lost (it once compared it with the
    last 2 s alone: a blocked drive in the first second went uncounted)."""
    reckoned = driven([FORWARD] * (3 * TICKS_PER_S), {})
    reckoned.mark(3000)
    reckoned.measured([report(3000, 0.0, lasted_ms=3000)], 3000)
    assert reckoned.slip.distance_m == LOST_M
    assert reckoned.drift(reckoned.placed(3000)).distance_m == 0.0


def test_a_push_between_two_reports_is_counted_by_the_next() -> None:
    """Taps forward (0.6 s in each second) against the table: the speed at each report's
    instant is 0, the distance over its second is not (a sampled speed missed it all)."""
    taps = [FORWARD if tick % TICKS_PER_S < 30 else Velocity() for tick in range(8 * TICKS_PER_S)]
    reckoned = driven([*taps, Velocity()], every_second(8))
    assert reckoned.slip.distance_m > 8 * 0.1


def test_what_no_report_covers_yet_counts_whole() -> None:
    """Reports that stopped after the first second: a reading's drift is the whole path
    reckoned since it; with a report each second, only the path since the last (0.5 s of
    driving); with none ever (a robot that sends none), nothing. A report of no duration
    covers nothing (a stream of them once cancelled everything): it says reports come, and
    the whole path since the start counts."""
    drive = [FORWARD] * (4 * TICKS_PER_S)
    first = reckoned_means(drive[:TICKS_PER_S])[1]
    stopped = driven(drive, {TICKS_PER_S: report(1000, first)})
    assert stopped.drift(stopped.placed(1000)).distance_m == pytest.approx(0.6, abs=0.01)
    assert driven(drive, {}).drift(stopped.placed(0)) == Slip()
    zero = {tick: report(tick * TICK_MS, 0.0, lasted_ms=0) for tick in range(len(drive))}
    nothing = driven(drive, zero)
    assert nothing.slip == Slip()
    assert nothing.drift(nothing.placed(0)).distance_m == pytest.approx(nothing.path_m)
    told = [FORWARD] * (3 * TICKS_PER_S + 25)
    made = reckoned_means(told[: 3 * TICKS_PER_S])
    reported = driven(told, every_second(3, lambda s: made[s]))
    assert reported.slip.distance_m == pytest.approx(ERROR * sum(made[1:4]))
    since = reported.placed(3000)
    assert reported.drift(since).distance_m == pytest.approx(0.1, abs=0.005)


def test_a_push_no_report_covers_yet_counts_at_a_persons_speed() -> None:
    """Standing still, a report each second telling 0: a reading's drift is what a person
    (1 m/s) could have pushed the base since the last report's end, or since the reading
    if later (a push between two reports is seen only by the next: an adversarial review
    had a child push the robot towards another unseen between two reports); since the
    start once the robot's first report (of no duration, at its start) came, as the review
    after found the first second blind; none before any report came (nothing tells a robot
    that sends none)."""
    still = [Velocity()] * (3 * TICKS_PER_S + TICKS_PER_S // 2)  # up to 3.5 s
    reported = driven(still, every_second(3), push_mps=1.0)
    assert reported.slip == Slip()
    assert reported.drift(reported.placed(0)).distance_m == pytest.approx(0.48, abs=1e-9)
    assert reported.drift(reported.placed(3200)).distance_m == pytest.approx(0.28, abs=1e-9)
    assert driven(still, {}, push_mps=1.0).drift(reported.placed(0)) == Slip()
    started = driven(still[: TICKS_PER_S - 1], every_second(0), push_mps=1.0)  # 0 to 0.96 s
    assert started.drift(started.placed(0)).distance_m == pytest.approx(0.96, abs=1e-9)
    lost = driven(still, every_second(3), push_mps=1e308)
    assert lost.drift(lost.placed(0)).distance_m == LOST_M  # finite


def test_the_path_between_two_reports_counts_whole() -> None:
    """Reports of the second half of each second only, telling 0.2 m/s (what the reckoning
    made but in the first half second's ramp): each uncovered half second's path counts
    (0.08 m for the first, 0.1 for the others), as the gaps once were lost for good, and so
    does a push over it (1 m/s for each half second)."""
    drive = [FORWARD] * (4 * TICKS_PER_S + 1)
    halves = {s * TICKS_PER_S: report(s * 1000, 0.2, lasted_ms=500) for s in range(1, 5)}
    told = 4 * ERROR * 0.1  # the reports' error
    reckoned = driven(drive, halves)
    assert reckoned.slip.distance_m == pytest.approx(0.08 + 3 * 0.1 + told, abs=0.005)
    pushed = driven(drive, halves, push_mps=1.0)
    assert pushed.slip.distance_m == pytest.approx(reckoned.slip.distance_m + 4 * 0.5)


def test_a_blocked_turn_slips_by_the_heading_it_did_not_make() -> None:
    """Spinning at 1 rad/s told 0: the whole turn reckoned slipped."""
    reckoned = driven([Velocity(0.0, 0.0, 1.0)] * (3 * TICKS_PER_S + 1), every_second(3))
    turned = reckoned.placed(3000).pose[2]
    assert reckoned.slip.heading_rad == pytest.approx(turned)
    assert reckoned.slip.distance_m == 0.0


def test_driving_on_after_a_blocked_turn_drifts_by_the_path_times_the_heading_slip() -> None:
    """A turn told 0 (blocked) for a second, then 3 s forward, each second told what the
    reckoning made: the reckoning faces the wrong way by the heading slip, so every metre
    driven since went that far off course (once left out: only a reading's distance times
    the heading slip counted)."""
    spin, turn_s, drive_s = Velocity(0.0, 0.0, 1.0), 1, 3
    velocities = [spin] * (turn_s * TICKS_PER_S) + [FORWARD] * (drive_s * TICKS_PER_S)
    forward = reckoned_means([FORWARD] * (drive_s * TICKS_PER_S))
    reports = {TICKS_PER_S: report(1000, 0.0, 0.0)}
    for s in range(1, drive_s + 1):  # what the reckoning made, in its own body frame
        reports[(turn_s + s) * TICKS_PER_S] = report((turn_s + s) * 1000, forward[s])
    reckoned = driven([*velocities, Velocity()], reports)
    heading = reckoned.slip.heading_rad
    assert heading > 0.5
    since = reckoned.drift(reckoned.placed(0))
    path = reckoned.path_m
    assert since.heading_rad == heading
    told = ERROR * sum(forward[1:])  # the reports' error
    assert since.distance_m == pytest.approx(path * heading + told, rel=0.02)


def test_a_report_covered_already_or_ahead_of_the_clock_counts_nothing() -> None:
    """A report seen again, an older one, and one that ends after now (a clock ahead: it
    once stopped every later report from counting) count nothing; the next one does."""
    reckoned = reckoning()
    reckoned.mark(0)
    reckoned.advance(Velocity(0.0, 0.0, 0.0))
    reckoned.mark(1000)
    ahead = SpeedStatus(xspeed=9.0, yspeed=0.0, thetaspeed=0.0, duration=5000, startingtime=1000)
    for speeds in ([report(1000, 1.0)], [report(1000, 1.0)], [report(400, 1.0)], [ahead]):
        reckoned.measured(speeds, 1000)
    assert reckoned.slip.distance_m == pytest.approx(1.0 + ERROR)
    reckoned.mark(2000)
    reckoned.measured([report(2000, 1.0)], 2000)
    assert reckoned.slip.distance_m == pytest.approx(2 * (1.0 + ERROR))


@pytest.mark.parametrize("forward", [math.nan, 1e308, -1e308])
def test_a_report_that_cannot_be_right_loses_the_reckoning_finitely(forward: float) -> None:
    """A NaN or absurd speed counts ``LOST_M``: every earlier reading is lost, and the
    arithmetic stays finite (an infinite slip once made a margin NaN)."""
    reckoned = reckoning()
    reckoned.mark(0)
    reckoned.measured([report(1000, forward)], 1000)
    assert reckoned.slip.distance_m == LOST_M
    later = reckoned.placed(1000)
    assert reckoned.drift(later).distance_m == 0.0


def _pushed(
    seconds: int,
    measured: float,
    *,
    ring: bool = False,
    echoed: bool = False,
    away_m: float = 1.0,
    config: SafetyConfig | None = None,
):
    """A child seen once, ``away_m`` to the left (then never again: stale; the ring's echo
    of them, kept, if ``echoed``); the robot driven 0.2 m/s forward for ``seconds``, told a
    mean speed of ``measured`` each second; a sonar ring on and scanning (that sees no
    echo) if ``ring``."""
    config = config or SafetyConfig(robot_radius_m=0.3)
    supervisor = SafetySupervisor(config, LIMITS, tick_ms=TICK_MS)
    left = math.pi / 2
    remembered = {"obstacles": [echo(away_m, left)]} if echoed else {"humans": [seen(away_m, left)]}
    sonars = [Sonar(id="ring", isonline=True)] if ring else []
    for tick in range(seconds * TICKS_PER_S + 1):
        now = tick * TICK_MS
        mean = 0.0 if now < 1000 else measured
        status = RobotStatus(speed=[report(now // 1000 * 1000, mean)])
        world_map = msgspec.structs.replace(room(), robotstatus=status, sonars=sonars, **remembered)
        supervise(FORWARD, world_map, now_ms=now, supervisor=supervisor)
    return supervisor, world_map


@pytest.mark.parametrize(("measured", "away_m", "free"), [(0.0, 1.0, False), (0.2, 2.3, True)])
def test_a_base_pushed_against_furniture_keeps_off_a_child_it_no_longer_sees(
    measured: float, away_m: float, free: bool
) -> None:
    """8 s against a table: the reckoning puts the child (1 m left) 1.6 m behind, but the
    measured speed (0) showed the slip, so driving left towards where the child may still
    be is stopped. Told the speed it reckoned, the same drive is free just after a report
    (nothing unchecked), with the child far enough left (2.3 m) that a push between two
    reports (1 m in a second) never brought them into the stop zone (nearer, the robot
    stops and goes: it cannot tell it was not pushed until the next report)."""
    supervisor, world_map = _pushed(8, measured, away_m=away_m)
    verdict, _ = supervise(Velocity(0.0, 0.2, 0.0), world_map, now_ms=8000, supervisor=supervisor)
    assert (verdict.velocity.v_y == pytest.approx(0.2)) is free
    if not free:
        assert verdict.velocity.v_y == pytest.approx(0.0, abs=1e-9)


def test_with_the_ring_working_slip_widens_nothing() -> None:
    """The same push with a working ring, which sees where the bodies are (here: no echo,
    nobody near): the child's stale reading keeps its margin (grown by every push, a
    reading the camera lost long ago froze the robot in the busy playroom)."""
    supervisor, world_map = _pushed(8, 0.0, ring=True)
    verdict, _ = supervise(Velocity(0.0, 0.2, 0.0), world_map, now_ms=8000, supervisor=supervisor)
    assert verdict.velocity.v_y == pytest.approx(0.2)


def test_the_map_type_is_what_the_supervisor_reads() -> None:
    assert WorldMap().robotstatus.speed == []


def test_a_kept_echo_is_not_taken_for_another_child_once_the_base_slipped() -> None:
    """The ring down, a child's echo kept 1.5 m to the left; 8 s against a table (told 0:
    0.6 m of slip, the drive slowed and bent away from the child). A second child seen
    where the reckoning places that echo: it is not that child (placed that far off, it
    may be anyone), so driving left, towards where the first child truly is, is still held
    back (it was taken for the second child and dropped: the robot drove into the first;
    found by an adversarial review)."""
    ideal = SafetyConfig(robot_radius_m=0.3, sonar_beam_rad=0.0)  # its echo a point, and
    supervisor, world_map = _pushed(8, 0.0, echoed=True, away_m=1.5, config=ideal)  # gated
    x, y, theta = supervisor.reckoned_pose  # where the reckoning has it: 0.6 m on
    assert math.hypot(x, y) > 0.5
    rho, bearing = math.hypot(-x, 1.5 - y), math.atan2(1.5 - y, -x) - theta  # at the echo
    other = seen(rho, bearing, at_ms=8000, ident="other")
    world_map = msgspec.structs.replace(world_map, humans=[other])
    verdict, _ = supervise(Velocity(0.0, 0.2, 0.0), world_map, now_ms=8000, supervisor=supervisor)
    assert verdict.velocity.v_y < 0.1


def test_a_report_ahead_of_the_clock_is_not_counted_when_the_clock_reaches_it() -> None:
    """A robot's clock 1.5 s ahead: its report, counted once the session's clock reached
    its stamp, moved the covered time past a push it never measured (the push bound
    counted nothing for the time it claimed). It is never counted: that time stays
    unchecked, and a person's push over it counts."""
    reckoned = reckoning(push_mps=1.0)
    on_time, ahead = report(1000), report(2500)  # ahead: (1500, 2500], sent at 1000
    since = None
    for now in range(0, 2501, TICK_MS):
        reckoned.mark(now)
        if now == 1000:
            reckoned.measured([on_time], now)  # covers up to 1000
            since = reckoned.placed(now)
        if now >= 1000:
            reckoned.measured([on_time, ahead], now)
        reckoned.advance(Velocity(0.0, 0.0, 0.0))
    assert since is not None
    assert reckoned.drift(since).distance_m == pytest.approx(1.5), "1.5 s of a 1 m/s push"


def test_ages_beyond_any_session_keep_every_state() -> None:
    """A status age of 10**23 ms (a scenario may state it) sized the history past a C size:
    an OverflowError built no supervisor (``--param robot.safety.max_status_age_ms=1`` and
    23 zeros)."""
    config = SafetyConfig(robot_radius_m=0.3, max_status_age_ms=10**23)
    supervisor = SafetySupervisor(config, LIMITS, tick_ms=TICK_MS)
    verdict, _ = supervise(Velocity(0.3, 0.0, 0.0), room(), supervisor=supervisor)
    assert verdict.velocity == (0.3, 0.0, 0.0)
