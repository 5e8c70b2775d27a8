"""What a scenario implies for the safety supervisor's assumptions (``[robot.safety]``).

The supervisor keeps the robot away from people by what it assumes of them and of its
sensing: the robot's and the humans' radii, how fast a human walks, how far off a reading
may be. In a simulated room those are known, and an assumption below them could let the
robot touch someone. So each one a scenario leaves out is taken from the scenario (never
below the supervisor's own default), and one it sets below the scenario's own is refused.
So is a status age shorter than two of the scenario's status periods (or a scan age shorter
than two of its ring's scans): the supervisor would take live sensors for dead between two
reports, and stop the robot.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Final, NamedTuple

from oimi.pipeline.act.echoes import arc_chord
from oimi.pipeline.act.safety_config import (
    ASSUMED,
    SafetyConfig,
    centre_reach_m,
    least_camera_range_m,
)
from oimi.pipeline.act.separation import stopping_way
from oimi.scenarios.schema import Scenario, SensorSpec, unit_of

NOISE_SIGMAS: Final = 3.0
"""How many standard deviations of the sensors' noise the sensing error covers."""
MISSED: Final = 1e-6
"""The chance the supervisor accepts that a sonar ring which drops detections misses a body
still there on every scan for ``echo_hold_ms`` (and so forgets it)."""


class Need(NamedTuple):
    """The least value an assumption may take, and whose it is."""

    least: float
    why: str
    """What it covers and what would go wrong below it, for a refusal."""


def needs(scenario: Scenario) -> dict[str, Need]:
    """The least value of each assumption the scenario implies (none it does not)."""
    robot, humans, sensors = scenario.robot, scenario.humans, scenario.sensors
    found = {
        "robot_radius_m": Need(
            robot.radius_m,
            f"the robot's radius_m {robot.radius_m!r}: the supervisor would let it touch people",
        )
    }
    if humans:
        big = max(humans, key=lambda h: h.radius_m)
        fast = max(humans, key=lambda h: h.max_speed_mps)
        found["human_radius_m"] = Need(
            big.radius_m,
            f"the radius_m {big.radius_m!r} of human {big.id!r}: the supervisor would let the"
            " robot touch them",
        )
        found["human_speed_mps"] = Need(
            fast.max_speed_mps,
            f"the max_speed_mps {fast.max_speed_mps!r} of human {fast.id!r}: the supervisor's"
            " margin would not cover their walk",
        )
    period_s = sensors.status_period_s
    two_periods_ms = _whole_ms(2 * period_s)
    found["max_status_age_ms"] = Need(
        two_periods_ms,
        f"two of the sensors' status_period_s {period_s!r} ({two_periods_ms} ms): the"
        " supervisor would take them for offline between two reports and stop the robot",
    )
    slower = min((sensors.rate_hz, "camera's frame"), (sensors.sonar_scan_hz, "sonar ring's scan"))
    period_ms = _whole_ms(1 / slower[0] + scenario.tick_ms / 1000)
    found["max_data_age_ms"] = Need(
        period_ms,
        f"the {slower[1]} and a tick ({period_ms} ms at {slower[0]!r} Hz): readings would"
        " age past it between two reports, their margins short of the walk since",
    )
    two_scans_ms = _whole_ms(2 / sensors.sonar_scan_hz)
    found["max_scan_age_ms"] = Need(
        two_scans_ms,
        f"two of the sonar ring's scans ({two_scans_ms} ms at sonar_scan_hz"
        f" {sensors.sonar_scan_hz!r}): the supervisor would take the ring for down between"
        " two scans and keep the robot to where the camera looks",
    )
    two_frames_ms = _whole_ms(2 / sensors.rate_hz)
    found["max_frame_age_ms"] = Need(
        two_frames_ms,
        f"two of the camera's frames ({two_frames_ms} ms at rate_hz {sensors.rate_hz!r}):"
        " the supervisor would take the camera for offline between two frames and slow the"
        " robot",
    )
    dropout = sensors.dropout_probability
    if 0 < dropout < 1:  # (sensors that never detect anything: coverage_gaps says so)
        scans = scans_to_see(dropout)
        hold_ms = _whole_ms(scans / sensors.sonar_scan_hz)
        found["echo_hold_ms"] = Need(
            hold_ms,
            f"{scans} of the sonar ring's scans ({hold_ms} ms at sonar_scan_hz"
            f" {sensors.sonar_scan_hz!r}) that all miss a body with dropout_probability"
            f" {dropout!r}: the supervisor would forget a child it has just stopped seeing",
        )
        for name, beats, rate, hz in (
            ("camera_miss_ms", "camera's frames", "rate_hz", sensors.rate_hz),
            ("sonar_miss_ms", "sonar ring's scans", "sonar_scan_hz", sensors.sonar_scan_hz),
        ):
            miss_ms = _whole_ms((scans - 1) / hz)
            found[name] = Need(
                miss_ms,
                f"{scans - 1} of the {beats} ({miss_ms} ms at {rate} {hz!r}) that may all miss"
                f" a child after the first with dropout_probability {dropout!r}: {_MISSED[name]}",
            )
    if sensors.noise_rho_m or sensors.noise_theta_rad:
        safety = robot.safety
        radii = (  # as the supervisor will take them (supervisor_config)
            _left_out(name, found) if (given := getattr(safety, name)) is None else given
            for name in ("robot_radius_m", "human_radius_m")
        )
        reach = sum(radii) + safety.stop_distance_m
        scaled = NOISE_SIGMAS * (sensors.noise_rho_m + sensors.noise_theta_rad * reach) * 1e4
        # up to 0.1 mm (not for a float's dust); a noise too large for any margin: infinite
        least = math.ceil(scaled - 1e-6) / 1e4 if math.isfinite(scaled) else math.inf
        found["sensing_error_m"] = Need(
            least,
            f"{NOISE_SIGMAS:g} times the sensors' noise ({least!r} m: noise_rho_m"
            f" {sensors.noise_rho_m!r}, and noise_theta_rad {sensors.noise_theta_rad!r} at the"
            f" stop zone's {round(reach, 3)!r} m): the supervisor's margin would not cover"
            " their errors",
        )
    return found


_MISSED: Final = {
    "camera_miss_ms": "with a sonar down the supervisor would count on seeing a child ahead"
    " sooner than it can",
    "sonar_miss_ms": "the supervisor would take a ring back for one that sees beside and"
    " behind the robot before it can",
}
"""What a camera's or a ring's misses, taken shorter than they are, would let happen."""


def _whole_ms(seconds: float) -> int:
    """``seconds`` in whole milliseconds, rounded up (not for a float's dust: 1.5005 s is
    1501 ms, 0.6666... s is 667)."""
    return math.ceil(seconds * 1000 - 1e-6)


def scans_to_see(dropout: float) -> float:
    """How many scans of a sensor that drops each detection with probability ``dropout``
    it takes to see a body there but for a chance of :data:`MISSED` (infinite: never)."""
    if dropout <= 0:
        return 1
    if dropout >= 1:
        return math.inf
    return math.ceil(math.log(MISSED) / math.log(dropout) - 1e-9)


NEVER_BELOW: Final = {
    name: value
    for name, value in ASSUMED.items()
    if name
    not in (
        "robot_radius_m",
        "camera_fov_rad",
        "camera_range_m",
        "sonar_beam_rad",
        "sonar_reports_surface",
    )
}
"""Below the supervisor's own assumptions, one left out is not taken even when the scenario
allows it (the robot's radius, the camera's view and range and the ring's beams aside: they
are the robot's own)."""


def beam_rad(sensors: SensorSpec) -> float:
    """How wide one sonar's beam of the scenario's ring is, rad (0: the ideal ring, which
    reports every body apart)."""
    return math.tau / sensors.sonar_beams if sensors.sonar_beams else 0.0


def supervisor_config(scenario: Scenario) -> SafetyConfig:
    """The scenario's ``[robot.safety]`` with what it leaves out taken from the scenario
    (the camera's field of view and range: its camera's; a sonar's beam, and whether it
    reports surfaces: its ring's, a merging one's do)."""
    implied = needs(scenario)
    return scenario.robot.safety.filled(
        **{name: _left_out(name, implied) for name in implied},
        camera_fov_rad=scenario.sensors.fov_rad,
        camera_range_m=scenario.sensors.range_m,
        sonar_beam_rad=beam_rad(scenario.sensors),
        sonar_reports_surface=scenario.sensors.sonar_beams > 0,
    )


def _left_out(name: str, implied: dict[str, Need]) -> float:
    """What the supervisor takes for assumption ``name`` when the scenario leaves it out:
    the least the scenario implies, never below the supervisor's own."""
    need = implied.get(name)
    return max(NEVER_BELOW.get(name, 0.0), 0.0 if need is None else need.least)


def unsafe_assumptions(scenario: Scenario) -> Iterator[tuple[tuple[str, ...], str]]:
    """Each assumption the scenario sets where the supervisor could let the robot touch
    someone: below what the scenario implies, a camera's view wider (or range longer)
    than its camera's, or surfaces stated for the ideal ring (it reports centres), as
    (path, message)."""
    safety = scenario.robot.safety
    for name, own, beyond, why in CAMERA:
        given, camera = getattr(safety, name), getattr(scenario.sensors, own)
        if given is not None and given > camera:
            yield (
                ("robot", "safety", name),
                f"{given!r} is {beyond} the camera's {own} {camera!r}: {why} (left out, it is"
                " taken from the scenario)",
            )
    beam = beam_rad(scenario.sensors)
    if safety.sonar_beam_rad is not None and safety.sonar_beam_rad < beam:
        yield (
            ("robot", "safety", "sonar_beam_rad"),
            f"{safety.sonar_beam_rad!r} is narrower than a sonar's beam of the ring"
            f" ({beam!r} rad: sonar_beams {scenario.sensors.sonar_beams!r}): the supervisor"
            " would take a child merged into a tracked child's echo for that child (left"
            " out, it is taken from the scenario)",
        )
    if safety.sonar_reports_surface and not scenario.sensors.sonar_beams:
        yield (
            ("robot", "safety", "sonar_reports_surface"),
            "true, but the ideal ring (sonar_beams 0) reports each body's centre: the"
            " supervisor would keep the echo's centre a radius beyond the body's; a real"
            " ring's scenario sets sonar_beams to its sonars (left out, it is taken from"
            " the scenario)",
        )
    for name, need in needs(scenario).items():
        if not math.isfinite(need.least):
            sensors = scenario.sensors
            yield (
                ("sensors", "noise_rho_m"),
                f"the sensors' noise (noise_rho_m {sensors.noise_rho_m!r}, noise_theta_rad"
                f" {sensors.noise_theta_rad!r}) is too large: {NOISE_SIGMAS:g} times it is no"
                " finite margin for the safety supervisor",
            )
            continue
        value = getattr(safety, name)
        if value is not None and value < need.least:
            yield (
                ("robot", "safety", name),
                f"{value!r} is below {need.why} (left out, it is taken from the scenario)",
            )


CAMERA: Final = (
    (
        "camera_fov_rad",
        "fov_rad",
        "wider than",
        "with the sonar ring down the supervisor would let the robot drive where nothing looks",
    ),
    (
        "camera_range_m",
        "range_m",
        "beyond",
        "the supervisor would take a child beyond it, never reported, merged into a tracked"
        " child's echo, for that child",
    ),
)
"""The camera's assumptions a scenario may not set beyond its camera's own (``[sensors]``):
each one's name, its camera's field, how it would exceed it and what would go wrong."""


PEOPLE: Final = ("human_radius_m", "human_speed_mps")
"""The assumptions about people."""


def unknown_people(scenario: Scenario) -> Iterator[tuple[tuple[str, ...], str]]:
    """Each assumption about people the scenario sets below the supervisor's own
    (:data:`~pipeline.act.safety_config.ASSUMED`), as (path, message): refusals for a real
    robot (``oimi bridge``), whose people the scenario's humans do not describe; and an
    ideal sonar ring (``sonar_beams`` 0, no ``sonar_beam_rad``): a real one merges the
    bodies in a beam into one echo, which the ideal ring's rule would take for a tracked
    child (``pipeline.act.echoes``)."""
    safety = scenario.robot.safety
    if not scenario.sensors.sonar_beams and safety.sonar_beam_rad is None:
        yield (
            ("sensors", "sonar_beams"),
            "0 is an ideal ring (every body reported apart): a real robot's sonars merge"
            " the bodies in one beam into one echo; set sonar_beams to its sonars (or"
            " [robot.safety] sonar_beam_rad to one's beam; the supervisor's own is"
            f" {ASSUMED['sonar_beam_rad']:.4g} rad)",
        )
    for name in PEOPLE:
        value = getattr(safety, name)
        if value is not None and value < ASSUMED[name]:
            yield (
                ("robot", "safety", name),
                f"{value!r} is below the supervisor's own {ASSUMED[name]!r} {unit_of(name)}: a real"
                " robot's people are not the scenario's, and a child may be larger or faster"
                " (left out, it is the larger of that and the scenario's humans')",
            )


def coverage_gaps(scenario: Scenario) -> Iterator[tuple[tuple[str, ...], str]]:
    """Where the sensors see a person too late for the supervisor to keep them out of the
    stop zone, as (path, message): warnings, not refusals (a scenario may study a faulty
    sensor, as ``tests/analysis/scenarios/scripted_collision.toml`` does).

    Beside and behind the robot only the sonar ring sees people. One who steps into its
    range is reported at its next scan (a ring that drops detections: at the scan by which
    it has seen them but for a chance of :data:`MISSED`) and acted on at the next tick; by
    then the robot, at its top speed, and the person, walking at ``human_speed_mps``, may
    have closed in by their speeds times that delay; then the robot brakes, at
    ``max_accel_mps2`` (no base stops at once), while
    the person walks on. The ring must reach farther than all that, plus both radii, the
    stop distance and the sensing error; on a ring whose beams merge (``sonar_beam_rad``
    > 0), and by what a drive across may close on an echo's arc (the robot's way, a tick
    and braking, times ``2 sin(beam / 4)``: ``SafetySupervisor._across``).

    While a sonar is down only the camera sees ahead, and only within its range: one that
    reports people nearer than :func:`~pipeline.act.separation.sighted_range_m` (a child
    walking at the robot seen in time) leaves the robot no linear motion then (it may only
    turn; with the ring up it drives)."""
    sensors, robot = scenario.sensors, scenario.robot
    config = supervisor_config(scenario)
    assert config.human_speed_mps is not None and config.sensing_error_m is not None
    assert config.robot_radius_m is not None and config.human_radius_m is not None
    scans = scans_to_see(sensors.dropout_probability)
    delay_s = scans / sensors.sonar_scan_hz + 1 / scenario.tick_hz
    speed, accel, walk = robot.max_speed_mps, robot.max_accel_mps2, config.human_speed_mps
    closing_m = (speed + walk) * delay_s
    braking_m = speed**2 / (2 * accel) + walk * speed / accel
    bodies_m = config.robot_radius_m + config.human_radius_m
    reach_m = centre_reach_m(config, config.stop_distance_m)
    least = reach_m + closing_m + braking_m
    assert config.sonar_beam_rad is not None
    arc_m = arc_chord(stopping_way(speed, 1 / scenario.tick_hz, accel), config.sonar_beam_rad)
    least += arc_m
    if sensors.sonar_range_m < least:
        yield (
            ("sensors", "sonar_range_m"),
            f"the sonar ring reaches {sensors.sonar_range_m!r} m, less than the"
            f" {round(least, 3)!r} m in which the safety supervisor can keep a person beside"
            f" or behind the robot out of its stop zone (both radii {round(bodies_m, 3)!r},"
            f" stop_distance_m {config.stop_distance_m!r}, sensing_error_m"
            f" {config.sensing_error_m!r}, and {round(closing_m, 3)!r} m closed in"
            f" {_scans_text(scans, sensors.dropout_probability)} and a tick at max_speed_mps"
            f" {speed!r} and human_speed_mps {walk!r}, and {round(braking_m, 3)!r} m while"
            f" it brakes at max_accel_mps2 {accel!r}{_arc_text(arc_m)}): the robot may touch"
            " someone it has not seen",
        )
    assert config.max_frame_age_ms is not None and config.camera_range_m is not None
    assert config.camera_miss_ms is not None
    sighted_m = least_camera_range_m(config, speed, accel, scenario.tick_ms / 1000)
    if config.camera_range_m < sighted_m:
        stated = robot.safety.camera_range_m is not None
        yield (
            ("robot", "safety", "camera_range_m") if stated else ("sensors", "range_m"),
            f"the camera reports people within {config.camera_range_m!r} m, less than the"
            f" {round(sighted_m, 3)!r} m in which the safety supervisor can stop the robot"
            f" before a child walking at it in its view whom it has not seen yet (the stop"
            f" zone's edge {round(reach_m, 3)!r} m, a frame's wait (max_frame_age_ms"
            f" {config.max_frame_age_ms!r}{_misses_text(config.camera_miss_ms)}) and a tick"
            f" at max_speed_mps {speed!r}, and its"
            f" braking at max_accel_mps2 {accel!r}, the child walking on at human_speed_mps"
            f" {walk!r}): while a sonar is down the robot only turns",
        )


def _arc_text(arc_m: float) -> str:
    if not arc_m:
        return ""
    return f", and {round(arc_m, 3)!r} m it may close on an echo's arc (sonar_beam_rad)"


def _misses_text(miss_ms: int) -> str:
    if not miss_ms:
        return ""
    return f" and camera_miss_ms {miss_ms!r} of frames that miss a child"


def _scans_text(scans: float, dropout: float) -> str:
    if scans == 1:
        return "a scan"
    if math.isinf(scans):
        return f"the scans that never see a body (dropout_probability {dropout!r})"
    return f"the {scans} scans that see a body with dropout_probability {dropout!r}"
