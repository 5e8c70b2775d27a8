"""What the safety supervisor is told (the scenario's ``[robot.safety]``) and what it
assumes where it is told nothing (:data:`ASSUMED`); the supervisor itself is
:mod:`~pipeline.act.safety`."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Final

import msgspec
from oimi.pipeline.act.separation import body_view, sighted_range_m
from oimi.pipeline.messages import Message

ASSUMED: Final[dict[str, float]] = {
    "robot_radius_m": 0.3,  # a pipeline without a scenario
    "human_radius_m": 0.25,  # unless a scenario's humans are larger
    "human_speed_mps": 1.0,  # unless a scenario's humans walk faster
    "sensing_error_m": 0.02,  # unless a scenario's sensor noise needs more
    "max_data_age_ms": 500,  # unless a scenario's sensors report less often: a period
    "max_status_age_ms": 2000,  # unless a scenario's status period is longer: one report
    # of a status repeated every second may be missed
    "camera_fov_rad": 1.0,  # a pipeline without a scenario: a narrow camera (57 degrees)
    "camera_range_m": 3.0,  # a pipeline without a scenario, or a real robot's camera unless
    # its range is stated (oimi bridge): a person tracker's short range (smaller keeps more
    # echoes: it costs stops, not safety)
    "echo_hold_ms": 2000,  # unless a scenario's ring misses bodies (dropouts): ten scans
    "max_scan_age_ms": 500,  # unless a scenario's ring scans slower: two of its scans
    "max_frame_age_ms": 500,  # unless a scenario's camera is slower: two of its frames
    "camera_miss_ms": 0,  # unless a scenario's camera drops people (dropouts): the frames
    # that may all miss a child; a real robot's person tracker that misses people states it
    "sonar_miss_ms": 0,  # unless a scenario's ring drops bodies (dropouts): the scans that may
    # all miss a child; a real robot's ring that misses bodies states it
    "sonar_beam_rad": math.pi / 3,  # a pipeline without a scenario, or a real robot's
    # ring (oimi bridge): wide, cheap sonars (60 degrees)
    "sonar_reports_surface": False,  # a pipeline without a scenario, or a real robot's
    # driver unless stated (oimi bridge): an echo's range may be a centre's
}
"""What the supervisor assumes for each assumption a configuration leaves open (None)."""


class SafetyConfig(Message):
    """The supervisor's zones and assumptions (the scenario's ``[robot.safety]``)."""

    robot_radius_m: float | None = None
    """The robot's radius, m; None: the robot's own ``radius_m`` (0.3 without a scenario)."""
    human_radius_m: float | None = None
    """Radius assumed for every human, m; None: the largest of 0.25 and the scenario's
    humans' ``radius_m`` (a scenario may not set it below one of theirs)."""
    stop_distance_m: float = 0.1
    """Surface distance below which nothing moves towards the human (protective stop), m."""
    slow_distance_m: float = 0.5
    """Surface distance below which the closing speed is capped at ``slow_speed_mps``, m."""
    slow_speed_mps: float = 0.2
    """Largest closing speed in the slow zone, and largest speed when sensing is stale, m/s."""
    max_data_age_ms: int | None = None
    """A human's position older than this (or a camera offline) is stale: slow-zone speed;
    the walk a reading's margin covers is capped at this age (an echo's at ``echo_hold_ms``,
    if longer), ms; None: the longer of 500 and
    a scenario's slower sensor's period (a camera frame or a sonar scan) and a tick (a
    scenario may not set it below that: readings would age past it between two reports,
    their margins short of the walk)."""
    human_speed_mps: float | None = None
    """Fastest a human is assumed to walk between readings (grows the uncertainty margin),
    m/s; None: the fastest of 1.0 and the scenario's humans' ``max_speed_mps`` (a scenario
    may not set it below one of theirs)."""
    sensing_error_m: float | None = None
    """Largest error of a reported position (noise, rounding), added to the margin, m; None:
    the larger of 0.02 and three times a scenario's sensor noise (a scenario may not set it
    below that)."""
    max_status_age_ms: int | None = None
    """A sensor whose status (``isonline``) was last heard longer ago than this counts as
    offline (its link is dead), and one heard more than three quarters of this ago caps
    the speed at ``slow_speed_mps``, ms; None: the longer of 2000 and two of a scenario's
    ``status_period_s`` (a scenario may not set it below that)."""
    echo_hold_ms: int | None = None
    """How long an echo the sonar ring stops reporting is kept (as a body still there) while
    every ring says it is on, before it counts as a body that left its range, ms: a ring
    that misses a body now and then (a dropout) would otherwise let the robot forget a
    child standing behind it. An echo's margin grows with the walk for as long as it is
    kept (a child the ring misses on a few scans walks on meanwhile); None: the longer of
    2000 and what a scenario's ``dropout_probability`` needs (a ring that misses a body on
    every scan of it has a chance below :data:`~scenarios.safety.MISSED` per body)."""
    camera_fov_rad: float | None = None
    """The front camera's horizontal field of view, rad, centred ahead. While a sonar of
    the ring is down (offline, silent or late) nothing sees beside or behind the robot, so
    linear motion stays inside this cone, narrowed so that a child centred just outside
    it beyond the slow zone stays out of the stop zone (``separation.body_view``): it
    drives only where a working sensor looks (a view of 1.35 rad or less: nowhere); None:
    the scenario's camera's ``fov_rad`` (1.0 without a scenario; a scenario may not set it
    above its camera's; 2 pi or more: it sees all around)."""
    odometry_error: float = 0.05
    """Largest error of the robot's measured motion (``RobotStatus speed``: its odometry's
    mean velocity over a report's interval), as a fraction of the distance (or turn) it
    measures. How far the distance over the interval differs from the dead reckoning's, plus
    this much of it, is what the base may have slipped (blocked by furniture, pushed): it
    widens every older reading's margin while a sonar is down; a turn, by the heading it may
    have turned."""
    max_scan_age_ms: int | None = None
    """A sonar whose latest scan (its ``scantime``, the ring's heartbeat) was taken longer
    ago than this, or never reported, counts as down, as one offline does: a ring frozen
    while it saw nothing still says it is on, and would otherwise pass for one that sees an
    empty room, ms; None: the longer of 500 and two of a scenario's sonar scans (a scenario
    may not set it below that)."""
    max_frame_age_ms: int | None = None
    """A camera whose latest frame (its ``frametime``, the camera's heartbeat) was taken
    longer ago than this, or never reported, counts as offline: a camera frozen while it
    saw nobody still says it is on, and would otherwise pass for one that sees an empty
    room, ms; None: the longer of 500 and two of a scenario's camera frames (a scenario may
    not set it below that)."""
    camera_miss_ms: int | None = None
    """How long the camera's frames may all miss a child in its view after the first frame
    that could have reported them, ms: while a sonar is down, a child ahead is seen that
    much later, and the camera's least range (``least_camera_range_m``) grows by what the
    robot and the child close in meanwhile. None: 0 (a camera that reports everyone in its
    view on every frame), or the frames that all miss a body with a scenario's
    ``dropout_probability`` but for a chance of :data:`~scenarios.safety.MISSED`, less the
    first (a scenario may not set it below that)."""
    sonar_miss_ms: int | None = None
    """How long the sonar ring's scans may all miss a body in a sonar's beam after the first
    scan that could have reported them, ms: a ring back (from offline, frozen or late, or at
    the start) counts as up only once every sonar has scanned this long without a break;
    until then the robot drives only where the camera looks, as with a sonar down. None: 0
    (a ring that reports every body on every scan), or the scans that all miss a body with
    a scenario's ``dropout_probability`` but for a chance of
    :data:`~scenarios.safety.MISSED`, less the first (a scenario may not set it below
    that)."""
    sonar_beam_rad: float | None = None
    """How wide one sonar's beam of the ring is, rad: a sonar reports the nearest body in
    its beam, so a child beside one the camera tracks may be merged into that child's echo,
    and gives a range, not a bearing: an echo is an arc, what made it anywhere within half a
    beam of its bearing (its margin grows to cover it). An echo is taken for a tracked human
    only where the camera's frame saw all that its beam may hold
    (:mod:`~pipeline.act.echoes`); 0: a ring that reports every body apart
    (the simulator's ideal ring), where an echo is a tracked human's only when it is the
    one echo near them; None: the scenario's ring's (``2 pi / sonar_beams``, 0 for the
    ideal ring; pi / 3 without a scenario and on a real robot, ``oimi bridge``; a scenario
    may not set it below its ring's)."""

    camera_range_m: float | None = None
    """The farthest from the robot's centre the camera reports a person's centre, m: an
    echo is taken for a tracked human only where the camera's frame would have reported
    any body that may have made it (:mod:`~pipeline.act.echoes`); a child beyond the range,
    never reported, merged into the tracked child's echo, would otherwise be driven into.
    While a sonar is down, a range shorter than ``separation.sighted_range_m`` (2.075 m by
    default) leaves no linear motion: a child ahead beyond it, walking at the robot, would
    be seen too late.
    None: the scenario's camera's ``range_m`` (3.0 without a scenario, and on a real robot
    whose scenario states no ``range_m``: ``oimi bridge``; a scenario may not set it
    beyond its camera's)."""
    sonar_reports_surface: bool | None = None
    """Whether each echo of a merging ring (``sonar_beam_rad`` > 0) gives the range of the
    nearest surface its sonar heard (a real sonar's raw range, the simulator's ring): the
    body whose nearest point that is then has its centre a radius farther out, and the
    supervisor keeps the echo's centre at its range plus ``human_radius_m``
    (:mod:`~pipeline.act.echoes`: a child's radius counted once, not twice). False: the
    range may be a body's centre's too, and the echo's centre stays at its range (it covers
    either). None: the scenario's ring's (true on a merging simulated ring, which reports
    surfaces; false on the ideal ring, which reports centres, and where it has no
    effect); false without a scenario and on a real robot (``oimi bridge``) unless stated
    (a scenario may not state it true for the ideal ring)."""

    def filled(self, **given: float) -> SafetyConfig:
        """This configuration with each assumption it leaves open (None) taken from
        ``given`` (by field name), else from :data:`ASSUMED`."""
        values = ASSUMED | given
        left_open = {name: values[name] for name in values if getattr(self, name) is None}
        return msgspec.structs.replace(self, **left_open)


def centre_reach_m(config: SafetyConfig, surface_m: float) -> float:
    """How far from the robot's centre a person's centre is on a fresh reading when their
    surfaces are ``surface_m`` apart (a filled ``config``: both radii and the sensing
    error), m: ``stop_distance_m``'s is the stop zone's edge."""
    radii = config.robot_radius_m + config.human_radius_m + config.sensing_error_m  # type: ignore[operator]  # filled
    return radii + surface_m


def least_camera_range_m(config: SafetyConfig, top_mps: float, a: float, dt_s: float) -> float:
    """:func:`~pipeline.act.separation.sighted_range_m` for a filled ``config`` (its stop
    zone's edge, walk and frame wait: a frame's age and the frames that may miss a child)
    and a robot at up to ``top_mps`` braking at ``a``."""
    wait_ms = config.max_frame_age_ms + config.camera_miss_ms  # type: ignore[operator]  # filled
    frame_s = wait_ms / 1000
    walk = config.human_speed_mps
    reach_m = centre_reach_m(config, config.stop_distance_m)
    return sighted_range_m(reach_m, top_mps, walk, frame_s, dt_s, a)  # type: ignore[arg-type]  # filled


def ring_down_view_rad(config: SafetyConfig, top_mps: float, a: float, dt_s: float) -> float:
    """While a sonar is down, how far from straight ahead the robot may drive, rad (a filled
    ``config``): the camera's half view narrowed so that a child centred outside it beyond
    the slow zone stays out of the stop zone (``separation.body_view``); negative, nowhere,
    where the camera's range is too short to report a child ahead in time
    (:func:`least_camera_range_m`)."""
    reach_m = centre_reach_m(config, config.stop_distance_m)
    slow_m = centre_reach_m(config, config.slow_distance_m)
    view = body_view(config.camera_fov_rad / 2, reach_m, slow_m)  # type: ignore[operator]  # filled
    least_m = least_camera_range_m(config, top_mps, a, dt_s)
    return view if config.camera_range_m >= least_m else -1.0  # type: ignore[operator]  # filled


def safety_problems(config: SafetyConfig) -> Iterator[tuple[str, str]]:
    """Every invalid value of ``config``, as (field, message)."""
    for name in config.__struct_fields__:
        value = getattr(config, name)
        if value is None:
            continue
        if not math.isfinite(value) or value < 0:
            yield name, f"safety {name} must be a non-negative number, got {value!r}"
    if config.slow_distance_m < config.stop_distance_m:
        yield (
            "slow_distance_m",
            f"safety slow_distance_m {config.slow_distance_m} is below stop_distance_m "
            f"{config.stop_distance_m}: the slow zone must contain the stop zone",
        )
