"""A body and sensors that are somewhere else: the session's world and sensors when the
robot is reached over ROS 2 (``oimi bridge``) or read from a rosbag2 (``oimi replay``).

``RemoteSensors`` hands the session the map updates that arrived since the last tick,
numbered in arrival order, their times moved from the robot's clock to the session's
(:class:`RobotClock`); ``RemoteBody`` keeps the robot's latest odometry for the
recorded world state. Neither simulates anything: scenario touches, faults and people's
behaviours belong to the real room and are ignored.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from typing import Final

import msgspec

from oimi.pipeline.events import BodyState, WorldState
from oimi.pipeline.messages import ActuatorOutputs, MapUpdate, Policy
from oimi.pipeline.sense.updates import INT_MAX
from oimi.pipeline.sink import NS_PER_MS
from oimi.ros2 import types
from oimi.scenarios.safety import supervisor_config
from oimi.scenarios.schema import BehaviourEvent, FaultEvent, Scenario, TouchEvent

CLOCK_WINDOW_MS: Final = 5000
"""How long, in session time, a sample of the robot's clock counts (at least twice the
scenario's ``max_data_age_ms``, ``max_scan_age_ms`` and ``max_frame_age_ms``:
:func:`clock_window_ms`). A robot
whose clock jumps back, restarted, is followed within it (its readings look older
meanwhile: the safe side); a frozen sensor's readings, repeated with their old times,
cannot make them look younger than it (they look that old, stale)."""
TIMES: Final = {
    "poses": ("positionchangetime",),
    "tracking": ("appearanceon",),
    "touch": ("startingtime",),
    "led": ("startingtime",),
    "audioout": ("startingtime",),
    "speed": ("startingtime",),
    "goalreached": ("timestamp",),
    "goalfailed": ("timestamp",),
    "goalinterrupted": ("timestamp",),
}
"""The times (ms) in each attribute's JSON payload (tables 4.1 and 4.2; durations stay)."""
BARE_TIMES: Final = frozenset({"startingtime", "scantime", "frametime"})
"""The attributes whose payload is a bare time (the robot's ``startingtime``, a sonar's
``scantime``, a camera's ``frametime``)."""
HEARTBEATS: Final = frozenset({"scantime", "frametime"})
"""The sensors' heartbeats: when a scan or a frame was taken."""


def clock_window_ms(*max_ages_ms: int) -> int:
    """The robot clock's window for a supervisor that takes readings older than
    ``max_data_age_ms``, and a ring or camera whose scan or frame is older than
    ``max_scan_age_ms`` or ``max_frame_age_ms``, as stale or down (``max_ages_ms``):
    :data:`CLOCK_WINDOW_MS`, or twice the longest of them if longer (a time repeated old
    looks as old as the window at most: it must look older than each)."""
    return max(CLOCK_WINDOW_MS, *(2 * age for age in max_ages_ms))


class RobotClock:
    """The robot's clock against the session's, from the times the robot sends.

    A map update's times (a pose's ``positionchangetime``, a touch's ``startingtime``...)
    are on the robot's clock, the clock of its odometry's stamps; the session's start at
    0 when the session does. A time the robot sends, taken at the session's ``now_ms``,
    bounds the clocks' offset: ``offset_ms`` is the least (session time at the tick that
    took it - robot time) over the samples of the last ``window_ms`` of session time (the
    latest is kept however old): the odometry's stamps, and the poses' own
    ``positionchangetime`` and the sensors' ``scantime`` and ``frametime`` (so a robot
    without ``/odom`` has a clock too). A reading thus
    keeps the age it had on the robot (younger by the promptest delivery at most, within
    the tick of age the supervisor's margin adds), and a sensor frozen on an old reading
    cannot make it look fresh: repeated, its samples only bound the offset from above."""

    def __init__(self, window_ms: int = CLOCK_WINDOW_MS) -> None:
        self.window_ms = window_ms
        self._samples: deque[tuple[int, int]] = deque()
        """(session ms, offset ms) in the order taken, each offset below the next: the
        least of the window first (a sample with another as low after it is dropped)."""

    def odometry(self, odometry: types.Odometry, *, now_ms: int) -> None:
        """An odometry message taken at the session's ``now_ms``."""
        stamp = odometry.header.stamp
        self.sample(stamp.sec * 1000 + stamp.nanosec // NS_PER_MS, now_ms=now_ms)

    def sample(self, robot_ms: int, *, now_ms: int) -> None:
        """A time on the robot's clock that reached the session at ``now_ms``."""
        offset = now_ms - robot_ms
        samples = self._samples
        while samples and samples[-1][1] >= offset:
            samples.pop()
        samples.append((now_ms, offset))
        while len(samples) > 1 and samples[0][0] <= now_ms - self.window_ms:
            samples.popleft()

    @property
    def offset_ms(self) -> int | None:
        """Session time minus robot time, ms; None before any time was received."""
        return self._samples[0][1] if self._samples else None


def on_session_clock(update: MapUpdate, moved: Callable[[int], int]) -> MapUpdate:
    """``update`` with each time its payload holds (:data:`TIMES`) taken through ``moved``
    (robot time -> session time). A payload that does not read as the tables say is left
    as it came, for the Map Producer to refuse with its reason."""
    return _moved(update, _timed_payload(update), moved)


def _timed_payload(update: MapUpdate) -> dict[str, object] | None:
    """The JSON object of an update whose attribute holds times (:data:`TIMES`), when each
    of them is a time the tables allow (None otherwise: nothing to move)."""
    keys = TIMES.get(update.attributename)
    if keys is None:
        return None
    try:
        payload = msgspec.json.decode(update.jsonmsg)
    except msgspec.DecodeError:
        return None
    if type(payload) is not dict or not all(_is_time(payload.get(key)) for key in keys):
        return None
    return payload


def _moved(
    update: MapUpdate, payload: dict[str, object] | None, moved: Callable[[int], int]
) -> MapUpdate:
    """:func:`on_session_clock` with the update's payload already read."""
    name = update.attributename
    if name in BARE_TIMES and (at := _bare_time(update.jsonmsg)) is not None:
        return msgspec.structs.replace(update, jsonmsg=str(moved(at)))
    if payload is None:
        return update
    for key in TIMES[name]:
        payload[key] = moved(payload[key])  # type: ignore[arg-type]
    return msgspec.structs.replace(update, jsonmsg=msgspec.json.encode(payload).decode())


def _taken_at(update: MapUpdate, payload: dict[str, object] | None) -> int | None:
    """When a reading was taken, on the robot's clock: a pose's ``positionchangetime``, a
    scan's ``scantime``, a frame's ``frametime`` (None: none, or no valid time)."""
    if update.attributename in HEARTBEATS:
        return _bare_time(update.jsonmsg)
    if payload is not None and update.attributename == "poses":
        return payload["positionchangetime"]  # type: ignore[return-value]  # a time
    return None


def _bare_time(text: str) -> int | None:
    """The time a bare payload holds, if it is one the tables allow."""
    at = int(text) if text.isascii() and text.isdigit() else None
    return at if _is_time(at) else None


def _is_time(value: object) -> bool:
    """Whether ``value`` is a time as the tables allow it (what is not is left for the Map
    Producer to refuse)."""
    return type(value) is int and 0 <= value <= INT_MAX


def remote_sensors(scenario: Scenario) -> RemoteSensors:
    """Remote sensors for a session of ``scenario``, their clock's window as long as its
    supervisor needs (:func:`clock_window_ms`)."""
    config = supervisor_config(scenario)
    assert config.max_scan_age_ms is not None and config.max_frame_age_ms is not None  # filled
    return RemoteSensors(
        max_data_age_ms=config.max_data_age_ms,
        max_scan_age_ms=config.max_scan_age_ms,
        max_frame_age_ms=config.max_frame_age_ms,
    )


class RemoteSensors:
    """The map updates received, given to the session once, at the next tick, their times
    on the session's clock (``clock``, fed with the robot's odometry and the poses' times;
    before the first, a time is the tick's that takes it), none later than that tick."""

    def __init__(
        self, *, max_data_age_ms: int = 500, max_scan_age_ms: int = 500, max_frame_age_ms: int = 500
    ) -> None:
        self._inbox: list[MapUpdate] = []
        self._seq = 0
        self.clock = RobotClock(clock_window_ms(max_data_age_ms, max_scan_age_ms, max_frame_age_ms))
        self.refused: list[str] = []
        """Why an update was refused before it reached the pipeline (read and cleared)."""

    def receive(self, update: types.MapUpdate) -> None:
        """A ``MapUpdate`` arrived; one with a policy other than R or A is refused."""
        try:
            policy = Policy(update.policy)
        except ValueError:
            self.refused.append(
                f"map update for {update.objectid!r}/{update.attributename!r} refused: "
                f"policy {update.policy!r} is not 'R' or 'A'"
            )
            return
        self._seq += 1
        self._inbox.append(
            MapUpdate(
                objectid=update.objectid,
                attributename=update.attributename,
                policy=policy,
                jsonmsg=update.jsonmsg,
                seq=self._seq,
            )
        )

    def sample(self, world: object, *, tick: int, time_ms: int) -> list[MapUpdate]:
        """The updates received since the last tick, in arrival order, on the session's
        clock."""
        updates, self._inbox = self._inbox, []
        payloads = [_timed_payload(update) for update in updates]
        for update, payload in zip(updates, payloads, strict=True):
            taken = _taken_at(update, payload)
            if taken is not None:
                self.clock.sample(taken, now_ms=time_ms)
        offset = self.clock.offset_ms

        def moved(at: int) -> int:  # never before the session, nor after the tick taking it
            return time_ms if offset is None else min(max(0, at + offset), time_ms)

        return [_moved(u, p, moved) for u, p in zip(updates, payloads, strict=True)]

    def touch(self, event: TouchEvent, *, time_ms: int) -> None:
        """Touches come from the robot's own sensors."""

    def fault(self, event: FaultEvent) -> None:
        """Faults happen to the robot's own sensors."""


class RemoteBody:
    """The robot as its odometry reports it; the LED and audio as oimi last asked."""

    def __init__(self, radius_m: float) -> None:
        self.radius_m = radius_m
        self.odometry = types.Odometry()
        self.led: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self.audio = ""

    def step(self, outputs: ActuatorOutputs, *, tick: int) -> None:
        """The body moves by itself."""

    def apply_event(self, event: BehaviourEvent) -> None:
        """People in the real room do as they please."""

    def state(self, *, tick: int, time_ms: int) -> WorldState:
        """The robot's latest reported pose and velocity (world frame)."""
        pose, twist = self.odometry.pose.pose, self.odometry.twist.twist
        q = pose.orientation
        theta = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
        cos, sin = math.cos(theta), math.sin(theta)
        vx, vy = twist.linear.x, twist.linear.y
        robot = BodyState(
            id="robot",
            kind="robot",
            x_m=round(pose.position.x, 6),
            y_m=round(pose.position.y, 6),
            theta_rad=round(theta, 6),
            vx_mps=round(cos * vx - sin * vy, 6),
            vy_mps=round(sin * vx + cos * vy, 6),
            omega_radps=round(twist.angular.z, 6),
            radius_m=self.radius_m,
        )
        return WorldState(tick=tick, time_ms=time_ms, robot=robot, led=self.led, audio=self.audio)


def odometry(
    *, time_ns: int, pose: tuple[float, float, float], velocity: tuple[float, float, float]
) -> types.Odometry:
    """An odometry message: ``pose`` (x m, y m, heading rad) in the odom frame,
    ``velocity`` (forward m/s, leftward m/s, turn rad/s) in the body frame."""
    x, y, theta = pose
    return types.Odometry(
        header=types.Header(stamp=types.stamp(time_ns), frame_id="odom"),
        child_frame_id="base_link",
        pose=types.PoseWithCovariance(
            pose=types.Pose(
                position=types.Point(x=x, y=y),
                orientation=types.Quaternion(z=math.sin(theta / 2), w=math.cos(theta / 2)),
            )
        ),
        twist=types.TwistWithCovariance(
            twist=types.Twist(
                linear=types.Vector3(x=velocity[0], y=velocity[1]),
                angular=types.Vector3(z=velocity[2]),
            )
        ),
    )


def outputs_of(twist: types.Twist, led: types.ColorRGBA, audio: types.String) -> ActuatorOutputs:
    """What the body is asked to do, from the last commands received (a non-finite
    number is read as 0: nothing received drives the body at an undefined speed)."""

    def finite(value: float) -> float:
        return value if math.isfinite(value) else 0.0

    return ActuatorOutputs(
        v_x=finite(twist.linear.x),
        v_y=finite(twist.linear.y),
        v_theta=finite(twist.angular.z),
        led=(finite(led.r), finite(led.g), finite(led.b)),
        audio=audio.data,
    )


def outputs_message(outputs: ActuatorOutputs) -> tuple[types.Twist, types.ColorRGBA, types.String]:
    """The commands that ask a body for ``outputs``."""
    r, g, b = outputs.led
    return (
        types.Twist(
            linear=types.Vector3(x=outputs.v_x, y=outputs.v_y),
            angular=types.Vector3(z=outputs.v_theta),
        ),
        types.ColorRGBA(r=r, g=g, b=b, a=1.0 if any(outputs.led) else 0.0),
        types.String(data=outputs.audio),
    )
