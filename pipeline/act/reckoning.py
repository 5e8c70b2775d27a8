"""The safety supervisor's dead reckoning: where the robot is in its own start frame.

Between readings the supervisor places what its sensors last saw by the robot's own motion:
the base is taken to follow the velocities let through at ``max_accel_mps2`` and
``max_angular_accel_radps2`` (a cut or a spin's end is braked to, not taken at once), as
the simulated base does. That model does not see a base blocked by furniture or pushed by
a person; the robot's measured speed (``RobotStatus speed``, table 4.1: its mean velocity
for ``duration`` ms from ``startingtime``, body frame) does. For each report, how far the
distance it says the base went differs from the distance reckoned over the same time, plus
the measurement's own error (``error``, a fraction of the distance measured: a base at a
stand measures none), is counted as *slip* (an allowance taken off it once let a child
lean the robot 1.3 m at 4 cm/s with nothing counted). Once reports come, a time none
covers (before the first, between two, or since the last one's end) is unchecked: the path
reckoned over it counts whole, and so does the way a person could have pushed the base
meanwhile (``push_mps``, the fastest a person moves, for that long: a push between two
reports is seen only by the next). A report that starts before the states kept cannot be
compared: the reckoning is lost. A robot that never sends a report has nothing counted.
A reading's position is uncertain by what was counted since it was taken
(:meth:`DeadReckoning.drift`), which the supervisor adds to its margin. No clock, no IO.
"""

from __future__ import annotations

import math
import sys
from collections import deque
from collections.abc import Sequence
from math import cos, hypot, remainder, sin
from typing import Final, NamedTuple

from oimi.pipeline.act.limits import RobotLimits, Velocity, fields, ramp_velocity
from oimi.pipeline.messages import SpeedStatus

LOST_M: Final = 1000.0
"""The most one report counts as slip (a report that cannot be read counts this much, and
the reckoning is lost for every reading taken before it), m or rad."""


class Slip(NamedTuple):
    """How far the reports say the reckoning drifted since the start."""

    distance_m: float = 0.0
    heading_rad: float = 0.0


class Placed(NamedTuple):
    """The reckoning at a reading's time: what its drift since is counted from."""

    at_ms: int
    pose: tuple[float, float, float]
    slip: Slip
    path_m: float


_NO_SLIP: Final = Slip()
"""No slip counted (one value for every reading placed before any report: a NamedTuple
built anew runs its ``__new__`` as Python)."""

_State = tuple[int, tuple[float, float, float], float]
"""A tick's time, ms, and the pose and the path's length (m) at its start (plain tuples:
one a tick)."""


AHEAD_KEPT: Final = 64
"""How many reports ahead of the clock are remembered (the map's register holds 16)."""


class DeadReckoning:
    """The robot's odometry pose, its base's velocity, and the slip its speed reports show."""

    def __init__(
        self,
        limits: RobotLimits,
        *,
        tick_ms: int,
        kept_ms: int,
        error: float,
        push_mps: float,
    ) -> None:
        self._limits = limits
        self._push_mps = push_mps
        """The fastest a person may push the base, m/s (over a time no report covers)."""
        self._error = error
        """A measured distance's or turn's error, as a fraction of it."""
        self._tick_ms = tick_ms
        self._dt_s = tick_ms / 1000
        self.pose = (0.0, 0.0, 0.0)
        """The robot's pose in its own start frame (m, m, rad)."""
        self._moving = Velocity()
        """The base's velocity as the reckoning takes it, in the odometry frame."""
        self._rested: Velocity | None = None
        """The velocity the last step reached standing (a target of zeros, reached): a
        step under that very velocity again leaves every value as it is (:meth:`advance`)."""
        self.path_m = 0.0
        """The length of the path the reckoning took the base along so far."""
        self._history: deque[_State] = deque(maxlen=min(kept_ms // tick_ms + 3, sys.maxsize))
        """Recent ticks' states at their start, oldest first (as many as ``kept_ms`` spans:
        for ages beyond any session, every state)."""
        self.slip = _NO_SLIP
        """The slip counted so far."""
        self._slips: deque[tuple[int, Slip]] = deque(maxlen=64)
        """Up to when each recent report was counted, ms, and the slip counted up to then."""
        self._covered_ms: float = -math.inf
        """Up to when the reports counted so far cover, ms: -inf before any came, then the
        start at least (a report of no duration, a robot's first, says reports come: what
        none covers since the start counts)."""
        self._covered_path_m = 0.0
        """The reckoned path at ``_covered_ms`` (what is driven since is unchecked)."""
        self._now_ms = 0
        """The current tick's time, ms."""
        self._ahead: dict[tuple[int, int], None] = {}
        """The (start, end) of the latest reports that came ending after their tick (a clock
        ahead; more than the map's register holds): never counted, so the time they claim
        stays unchecked, a push over it too."""

    def mark(self, now_ms: int) -> None:
        """Keep the state at the start of the tick at ``now_ms`` (once per tick)."""
        self._now_ms = now_ms
        if not self._history or self._history[-1][0] != now_ms:
            self._history.append((now_ms, self.pose, self.path_m))

    def placed(self, time_ms: int) -> Placed:
        """The reckoning at ``time_ms``: the pose then (the oldest kept for older times), the
        slip counted up to the last report that covers it and the path driven up to then
        (for a time older than what is kept, none: all that was counted since the start)."""
        at_ms, pose, path_m = self._state_at(time_ms)
        slip = _NO_SLIP
        for until_ms, counted in reversed(self._slips):
            if until_ms <= time_ms:
                slip = counted
                break
        return fields(Placed, (time_ms, pose, slip, path_m if at_ms <= time_ms else 0.0))

    def drift(self, since: Placed) -> Slip:
        """How far the reckoning may have drifted since ``since``: the slip counted since,
        and over the time since the reports last covered (or since ``since``) the path
        driven and a person's push (at most ``LOST_M``); and the path driven since with a
        heading that far off. A robot that never reported its speed has no drift counted:
        nothing tells a blocked or pushed base."""
        slip = self.slip
        unchecked = 0.0
        if self._covered_ms > -math.inf:  # reports come: what they do not cover yet counts
            unchecked_ms = self._now_ms - max(since.at_ms, self._covered_ms)
            pushed = self._push_mps * unchecked_ms / 1000 if unchecked_ms > 0 else 0.0
            unchecked = self.path_m - max(since.path_m, self._covered_path_m) + _counted(pushed)
        heading = slip.heading_rad - since.slip.heading_rad
        if heading:  # each metre driven since went that far off course
            unchecked += (self.path_m - since.path_m) * min(heading, math.pi)
        return fields(Slip, (slip.distance_m - since.slip.distance_m + unchecked, heading))

    def swept(self, start_ms: int, end_ms: int) -> Slip | None:
        """How far the reckoning took the robot, from ``start_ms`` to ``end_ms``, from where
        it was at ``end_ms``: the path it drove (no pose then lay farther) and the largest
        turn off its heading then. None: the states from ``start_ms`` on are not all kept."""
        history = self._history
        if not history or history[0][0] > start_ms:
            return None
        _, (_, _, heading), end_path_m = self._state_at(end_ms)
        off, start_path_m = 0.0, end_path_m
        for at_ms, (_, _, theta), path_m in reversed(history):  # (back to the state at start)
            if at_ms > end_ms:
                continue
            off = max(off, abs(remainder(theta - heading, math.tau)))
            if at_ms <= start_ms:
                start_path_m = path_m
                break
        return Slip(end_path_m - start_path_m, off)

    def measured(self, speeds: Sequence[SpeedStatus], now_ms: int) -> None:
        """Count the slip the reports in ``speeds`` (the map's register, oldest first) not
        counted yet show, in order."""
        covered = self._covered_ms
        if not speeds or _end_ms(speeds[-1]) <= covered:
            return  # most ticks: nothing new
        new: list[SpeedStatus] = []
        for speed in reversed(speeds):
            if _end_ms(speed) <= covered:
                break
            new.append(speed)
        for speed in reversed(new):
            self._count(speed, now_ms)

    def _count(self, speed: SpeedStatus, now_ms: int) -> None:
        """Count the slip a speed report shows: the distance its mean velocity over its
        ``duration`` makes, against the distance reckoned over that time, plus its error;
        and the time before it that no report covers. A report covered already, or ending
        after the current tick (a clock ahead) changes nothing, then or when the clock reaches
        it (it would cover a push since); one that starts before the states kept counts
        ``LOST_M``."""
        start_ms, end_ms = speed.startingtime, _end_ms(speed)
        covered = self._covered_ms = max(self._covered_ms, 0)
        if end_ms > now_ms:  # its clock is ahead: what it says cannot be placed, ever
            self._ahead[start_ms, end_ms] = None
            if len(self._ahead) > AHEAD_KEPT:
                del self._ahead[next(iter(self._ahead))]
            return
        if end_ms <= covered or start_ms >= end_ms or (start_ms, end_ms) in self._ahead:
            return  # (one of no duration covers nothing)
        history = self._history
        if history and start_ms < history[0][0]:  # what the base was told then is gone
            self._covered_ms, self._covered_path_m = end_ms, self._state_at(end_ms)[2]
            self._add(Slip(LOST_M, LOST_M), end_ms)
            return
        forward, left, turn, start_path_m, end_path_m = self._driven(start_ms, end_ms)
        gap_m = 0.0
        if covered < start_ms:  # a time no report covers: its path, and a push meanwhile
            gap_m = start_path_m - self._covered_path_m
            gap_m += _counted(self._push_mps * (start_ms - covered) / 1000)
        self._covered_ms, self._covered_path_m = end_ms, end_path_m
        lasted_s = speed.duration / 1000
        went_x, went_y, turned = (
            speed.xspeed * lasted_s,
            speed.yspeed * lasted_s,
            speed.thetaspeed * lasted_s,
        )
        error = self._error
        gap = hypot(went_x - forward, went_y - left) + error * hypot(went_x, went_y)
        turn = abs(turned - turn) + error * abs(turned)
        if gap_m or not (gap <= 0.0 and turn <= 0.0):  # (as reckoned, at a stand: nothing)
            self._add(Slip(_counted(gap) + gap_m, _counted(turn)), end_ms)

    def _add(self, more: Slip, until_ms: int) -> None:
        """Count ``more`` slip, up to ``until_ms``."""
        slip = self.slip
        self.slip = Slip(slip.distance_m + more.distance_m, slip.heading_rad + more.heading_rad)
        self._slips.append((until_ms, self.slip))

    def advance(self, velocity: Velocity) -> None:
        """One tick of the base towards ``velocity`` (body frame, turned into the odometry
        frame with the heading at the start of the step), changing by the largest
        accelerations at most: it rolls and spins on after a cut."""
        if velocity is self._rested:  # standing, told to stand: the step would change nothing
            return
        x, y, theta = self.pose
        cos_t, sin_t = cos(theta), sin(theta)
        target = fields(
            Velocity,
            (
                cos_t * velocity.v_x - sin_t * velocity.v_y,
                sin_t * velocity.v_x + cos_t * velocity.v_y,
                velocity.v_theta,
            ),
        )
        moving = self._moving = ramp_velocity(
            self._moving, target, self._limits, dt_ms=self._tick_ms
        )
        v_x, v_y, omega = moving
        # (reached and all zero: the pose, never -0.0, stays; the next target, made of the
        # same bits, is reached again at once)
        self._rested = velocity if moving is target and not (v_x or v_y or omega) else None
        dt = self._dt_s
        theta += dt * omega
        self.pose = (x + dt * v_x, y + dt * v_y, theta)
        if v_x or v_y:
            self.path_m += dt * hypot(v_x, v_y)

    @property
    def speed(self) -> float:
        """The base's linear speed as the reckoning takes it, m/s."""
        return hypot(self._moving.v_x, self._moving.v_y)

    @property
    def velocity(self) -> tuple[float, float]:
        """The base's linear velocity as the reckoning takes it, in the body frame."""
        cos_t, sin_t = cos(self.pose[2]), sin(self.pose[2])
        m_x, m_y, _ = self._moving
        return cos_t * m_x + sin_t * m_y, cos_t * m_y - sin_t * m_x

    def _driven(self, start_ms: int, end_ms: int) -> tuple[float, float, float, float, float]:
        """What the reckoning took the base to drive from ``start_ms`` to ``end_ms`` (from the
        oldest state kept, for an older start), as its odometry would measure it: each tick's
        step in the body frame after it (m forward, m left) and the turn (rad); and the
        path's length at both ends. (Worked out here, once a report, not at every tick.)"""
        forward = left = 0.0
        history = self._history
        if not history:
            return 0.0, 0.0, 0.0, self.path_m, self.path_m
        first = len(history) - 1
        while first > 0 and history[first][0] > start_ms:
            first -= 1
        at_ms, (x, y, theta), path_m = history[first]
        turned, start_path_m = theta, path_m
        for index in range(first + 1, len(history)):
            at_ms, (next_x, next_y, next_theta), next_path_m = history[index]
            if at_ms > end_ms:
                break
            cos_t, sin_t = cos(next_theta), sin(next_theta)
            dx, dy = next_x - x, next_y - y
            forward += cos_t * dx + sin_t * dy
            left += cos_t * dy - sin_t * dx
            x, y, theta, path_m = next_x, next_y, next_theta, next_path_m
        return forward, left, theta - turned, start_path_m, path_m

    def _state_at(self, time_ms: int) -> _State:
        for state in reversed(self._history):
            if state[0] <= time_ms:
                return state
        return self._history[0] if self._history else (time_ms, self.pose, self.path_m)


def _counted(excess: float) -> float:
    """What a report's excess over the error counts: none below it, at most ``LOST_M`` (and
    that much for one that is not a number)."""
    if excess <= 0.0:
        return 0.0
    return excess if excess < LOST_M else LOST_M


def _end_ms(speed: SpeedStatus) -> int:
    """When a speed report's interval ends, ms."""
    return speed.startingtime + speed.duration
