"""The safety supervisor and a child the camera lost (their map row ages): stale, so the
robot is slow, until every sonar ring has scanned since the camera last reported them, on a
ring that reports every body apart; then the ring's echo of them stands in for their row. On
a ring that merges what its beams hold the row counts, stale, as before (a child behind
nearer bodies in every beam would be lost to both sensors)."""

from __future__ import annotations

import math

import pytest
from oimi.pipeline.act.limits import Velocity
from oimi.pipeline.act.safety import SafetySupervisor
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.events import SafetyZone
from oimi.pipeline.messages import Sonar
from supervision import LIMITS, TICK_MS, echo, live, room, seen, supervise

NOW_MS = 900
"""The camera's last reading of the child was taken at 300 ms (600 ms old, past
``max_data_age_ms``, 500) and came at 350 ms."""


def apart(**given: float) -> SafetySupervisor:
    """A supervisor whose ring reports every body apart (``sonar_beam_rad`` 0), and
    ``given`` (by field name)."""
    config = SafetyConfig(robot_radius_m=0.3, sonar_beam_rad=0.0, **given)
    return SafetySupervisor(config, LIMITS, tick_ms=TICK_MS)


def behind(*, echoed: bool = True):
    """A child the camera saw 1.3 m behind the robot at 300 ms (reported at 350), and a
    ring that reports them 0.95 m behind now (an echo of this tick) unless ``echoed`` is
    false."""
    lost = room(seen(1.3, math.pi, at_ms=300))
    lost.sonars.append(Sonar(id="ring", isonline=True))
    if echoed:
        lost.obstacles.append(echo(0.95, math.pi, at_ms=NOW_MS))
    heard = live(lost, NOW_MS) | {("Human", "child"): 350, ("Obstacle", "echo-0"): NOW_MS}
    return lost, heard


def test_a_child_the_camera_lost_does_not_hold_the_robot_slow_once_the_ring_scanned_since() -> None:
    lost, heard = behind()
    away, _ = supervise(
        Velocity(0.5, 0.0, 0.0), lost, now_ms=NOW_MS, heard=heard, supervisor=apart()
    )
    assert away.velocity == (0.5, 0.0, 0.0) and away.zone is None


def test_the_rings_echo_stands_in_for_the_lost_child() -> None:
    """Reversing at them: the echo (fresh, in the slow zone) caps the closing speed."""
    lost, heard = behind()
    back, event = supervise(
        Velocity(-0.5, 0.0, 0.0), lost, now_ms=NOW_MS, heard=heard, supervisor=apart()
    )
    assert back.zone is SafetyZone.SLOW and event is not None
    assert event.human == "Obstacle/echo-0"
    assert back.velocity[0] == pytest.approx(-0.2)


def test_the_child_is_lost_once_the_camera_has_not_reported_them_for_max_data_age() -> None:
    """Reported 550 ms ago: lost, and the ring (scanning now) has looked all round
    since. Reported 450 ms ago: not yet lost (a frame or two missed), so stale."""
    lost, heard = behind(echoed=False)
    away, _ = supervise(
        Velocity(0.5, 0.0, 0.0), lost, now_ms=NOW_MS, heard=heard, supervisor=apart()
    )
    assert away.velocity == (0.5, 0.0, 0.0) and away.zone is None
    heard[("Human", "child")] = NOW_MS - 450
    early, _ = supervise(
        Velocity(0.5, 0.0, 0.0), lost, now_ms=NOW_MS, heard=heard, supervisor=apart()
    )
    assert early.velocity == pytest.approx((0.2, 0.0, 0.0)) and early.zone is SafetyZone.STALE


def test_with_the_ring_down_the_lost_child_keeps_the_robot_slow() -> None:
    """(The scenarios' camera, 2.2 rad: the default's, 1 rad, leaves no direction to drive
    in with the ring down.)"""
    lost, heard = behind(echoed=False)
    lost.sonars[0].isonline = False
    front = apart(camera_fov_rad=2.2)
    away, _ = supervise(Velocity(0.5, 0.0, 0.0), lost, now_ms=NOW_MS, heard=heard, supervisor=front)
    assert away.velocity == pytest.approx((0.2, 0.0, 0.0))
    assert away.zone in (SafetyZone.STALE, SafetyZone.BLIND)


def test_on_a_merging_ring_the_lost_child_still_counts() -> None:
    """Sonars 60 degrees wide (the supervisor's own assumption, a real robot's ring): the
    ring's silence about the child may be a nearer body hiding them, so their row keeps
    the robot slow and, reversing at where they were, stops it short of them."""
    lost, heard = behind(echoed=False)
    away, _ = supervise(Velocity(0.5, 0.0, 0.0), lost, now_ms=NOW_MS, heard=heard)
    assert away.velocity == pytest.approx((0.2, 0.0, 0.0)) and away.zone is SafetyZone.STALE
    back, event = supervise(Velocity(-0.5, 0.0, 0.0), lost, now_ms=NOW_MS, heard=heard)
    assert back.zone is not None and event is not None and event.human == "child"


def test_a_camera_still_reporting_the_child_late_keeps_them_stale() -> None:
    """The camera keeps sending the child, each reading 600 ms old (a lagging camera): not
    lost, so the row counts, stale, even in the ticks after a scan and before a frame."""
    lost, heard = behind()
    heard[("Human", "child")] = NOW_MS - 40
    away, _ = supervise(
        Velocity(0.5, 0.0, 0.0), lost, now_ms=NOW_MS, heard=heard, supervisor=apart()
    )
    assert away.velocity == pytest.approx((0.2, 0.0, 0.0)) and away.zone is SafetyZone.STALE
