"""The safety supervisor's dead reckoning: where the robot is in its own start frame.

Between readings the supervisor places what its sensors last saw by the robot's own motion:
the base is taken to follow the velocities let through at ``max_accel_mps2`` and
``max_angular_accel_radps2`` (a cut or a spin's end is braked to, not taken at once), as
the simulated base does. That model does not see a base blocked by furniture or pushed by
a person; the robot's measured speed (``RobotStatus speed``, table 4.1) does. Each time a
new one comes, how far it differs from the reckoned velocity at the time it was taken,
beyond the measurement's error, is counted as *slip* for the whole time since the previous
one: the reckoning may have drifted that far. A reading's position is then uncertain by the
slip counted since it was taken (:attr:`DeadReckoning.slip` less
:meth:`DeadReckoning.slip_at` its time), which the supervisor adds to its margin.
No clock, no IO.
"""

from __future__ import annotations

import math
from collections import deque
from typing import NamedTuple

from oimi.pipeline.act.limits import RobotLimits, Velocity, ramp_velocity
from oimi.pipeline.messages import SpeedStatus


class Slip(NamedTuple):
    """How far the reckoning may have drifted since the session started."""

    distance_m: float = 0.0
    heading_rad: float = 0.0


class DeadReckoning:
    """The robot's odometry pose, its base's velocity, and the slip its speed reports show."""

    def __init__(
        self, limits: RobotLimits, *, tick_ms: int, kept_ms: int, error_mps: float, radius_m: float
    ) -> None:
        self._limits = limits
        self._error_mps = error_mps
        """A measured speed's error: a difference up to it is no slip, m/s."""
        self._error_radps = error_mps / radius_m if radius_m > 0 else math.inf
        """A measured turn rate's error (the speed's at the robot's rim), rad/s."""
        self._tick_ms = tick_ms
        self._dt_s = tick_ms / 1000
        self.pose = (0.0, 0.0, 0.0)
        """The robot's pose in its own start frame (m, m, rad)."""
        self._moving = Velocity()
        """The base's velocity as the reckoning takes it, in the odometry frame."""
        self._history: deque[tuple[int, tuple[float, float, float], Velocity]] = deque(
            maxlen=kept_ms // tick_ms + 3
        )
        """Recent ticks' (time, pose, velocity) at their start, oldest first."""
        self.slip = Slip()
        """The slip counted so far."""
        self._slips: deque[tuple[int, Slip]] = deque(maxlen=64)
        """When each recent speed report was taken, ms, and the slip counted up to it."""
        self._measured_ms: int | None = None
        """When the latest speed report counted was taken, ms."""

    def mark(self, now_ms: int) -> None:
        """Keep the pose at the start of the tick at ``now_ms`` (once per tick)."""
        if not self._history or self._history[-1][0] != now_ms:
            self._history.append((now_ms, self.pose, self._moving))

    def pose_at(self, time_ms: int) -> tuple[float, float, float]:
        """The odometry pose at ``time_ms`` (the oldest kept for older times)."""
        return self._state_at(time_ms)[1]

    def slip_at(self, time_ms: int) -> Slip:
        """The slip counted up to the latest speed report taken at ``time_ms`` or before
        (none for a time older than the reports kept: all the slip since is then counted
        for a reading taken at that time)."""
        for at_ms, slip in reversed(self._slips):
            if at_ms <= time_ms:
                return slip
        return Slip()

    def measured(self, speed: SpeedStatus) -> None:
        """Count the slip a speed report shows (body frame, taken at ``startingtime``): the
        difference from the reckoned velocity then, taken to have held since the previous
        report. A report counted already, or older than it, changes nothing."""
        at_ms = speed.startingtime
        previous = self._measured_ms
        if previous is not None and at_ms <= previous:
            return
        self._measured_ms = at_ms
        _, (_, _, theta), moving = self._state_at(at_ms)
        cos, sin = math.cos(theta), math.sin(theta)
        forward = cos * moving.v_x + sin * moving.v_y
        left = -sin * moving.v_x + cos * moving.v_y
        lasted_s = 0.0 if previous is None else (at_ms - previous) / 1000
        gap = math.hypot(speed.xspeed - forward, speed.yspeed - left) - self._error_mps
        turn = abs(speed.thetaspeed - moving.v_theta) - self._error_radps
        if gap <= 0.0 and turn <= 0.0:
            return  # within the measurement's error: the reckoning holds
        if not (math.isfinite(gap) and math.isfinite(turn)):
            gap, turn = math.inf, math.pi  # a report that cannot be read: lost
        slip = self.slip
        self.slip = Slip(
            slip.distance_m + max(gap, 0.0) * lasted_s,
            slip.heading_rad + max(turn, 0.0) * lasted_s,
        )
        self._slips.append((at_ms, self.slip))

    def advance(self, velocity: Velocity) -> None:
        """One tick of the base towards ``velocity`` (body frame, turned into the odometry
        frame with the heading at the start of the step), changing by the largest
        accelerations at most: it rolls and spins on after a cut."""
        x, y, theta = self.pose
        cos, sin = math.cos(theta), math.sin(theta)
        target = Velocity(
            cos * velocity.v_x - sin * velocity.v_y,
            sin * velocity.v_x + cos * velocity.v_y,
            velocity.v_theta,
        )
        v_x, v_y, omega = self._moving = ramp_velocity(
            self._moving, target, self._limits, dt_ms=self._tick_ms
        )
        dt = self._dt_s
        self.pose = (x + dt * v_x, y + dt * v_y, theta + dt * omega)

    def _state_at(self, time_ms: int) -> tuple[int, tuple[float, float, float], Velocity]:
        for state in reversed(self._history):
            if state[0] <= time_ms:
                return state
        return self._history[0] if self._history else (time_ms, self.pose, self._moving)
