"""The safety supervisor and a child the camera lost (their map row ages): stale, so the
robot is slow, until every sonar ring has scanned since the camera last reported them;
then the ring's echo of them stands in for their row."""

from __future__ import annotations

import math

import pytest
from oimi.pipeline.act.limits import Velocity
from oimi.pipeline.events import SafetyZone
from oimi.pipeline.messages import Sonar
from supervision import echo, live, room, seen, supervise

NOW_MS = 900
"""The camera's last reading of the child was taken at 300 ms (600 ms old, past
``max_data_age_ms``, 500) and came at 500 ms."""


def behind(*, echoed: bool = True):
    """A child the camera saw 1.3 m behind the robot at 300 ms (reported at 500), and a
    ring that reports them 0.95 m behind now (an echo of this tick) unless ``echoed`` is
    false."""
    lost = room(seen(1.3, math.pi, at_ms=300))
    lost.sonars.append(Sonar(id="ring", isonline=True))
    if echoed:
        lost.obstacles.append(echo(0.95, math.pi, at_ms=NOW_MS))
    heard = live(lost, NOW_MS) | {("Human", "child"): 500, ("Obstacle", "echo-0"): NOW_MS}
    return lost, heard


def test_a_child_the_camera_lost_does_not_hold_the_robot_slow_once_the_ring_scanned_since() -> None:
    lost, heard = behind()
    away, _ = supervise(Velocity(0.5, 0.0, 0.0), lost, now_ms=NOW_MS, heard=heard)
    assert away.velocity == (0.5, 0.0, 0.0) and away.zone is None


def test_the_rings_echo_stands_in_for_the_lost_child() -> None:
    """Reversing at them: the echo (fresh, in the slow zone) caps the closing speed."""
    lost, heard = behind()
    back, event = supervise(Velocity(-0.5, 0.0, 0.0), lost, now_ms=NOW_MS, heard=heard)
    assert back.zone is SafetyZone.SLOW and event is not None
    assert event.human == "Obstacle/echo-0"
    assert back.velocity[0] == pytest.approx(-0.2)


def test_until_every_ring_has_scanned_since_the_lost_child_is_stale() -> None:
    """The ring's latest scan was taken before the camera's last report (450 < 500 ms):
    it has not looked all round since, so the child's row still counts, stale."""
    lost, heard = behind(echoed=False)
    away, _ = supervise(
        Velocity(0.5, 0.0, 0.0), lost, now_ms=NOW_MS, heard=heard, scanned={"ring": 550}
    )
    assert away.velocity == (0.5, 0.0, 0.0) and away.zone is None
    early, _ = supervise(
        Velocity(0.5, 0.0, 0.0), lost, now_ms=NOW_MS, heard=heard, scanned={"ring": 450}
    )
    assert early.velocity == pytest.approx((0.2, 0.0, 0.0)) and early.zone is SafetyZone.STALE


def test_with_the_ring_down_the_lost_child_keeps_the_robot_slow() -> None:
    lost, heard = behind(echoed=False)
    lost.sonars[0].isonline = False
    away, _ = supervise(Velocity(0.5, 0.0, 0.0), lost, now_ms=NOW_MS, heard=heard)
    assert away.velocity == pytest.approx((0.2, 0.0, 0.0))
    assert away.zone in (SafetyZone.STALE, SafetyZone.BLIND)
