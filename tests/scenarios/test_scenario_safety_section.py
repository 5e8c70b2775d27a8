"""The scenario's ``[robot.safety]`` section: decoded, defaulted, checked, recorded."""

from __future__ import annotations

import msgspec
import pytest
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.loader import parse_scenario, warnings_with
from oimi.scenarios.real_robot import (
    check_real_people,
    real_robot_overrides,
    real_robot_warnings,
)
from oimi.scenarios.session.build import pipeline_config
from oimi.scenarios.session.runner import Session


def refused(text: bytes) -> str:
    """The located error the scenario ``text`` (read as ``s.toml``) is refused with."""
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(text, source="s.toml")
    return str(caught.value)


def test_the_supervisor_is_on_by_default_with_the_robot_radius() -> None:
    loaded = parse_scenario(b'name = "x"\n[robot]\nradius_m = 0.35\n')
    assert loaded.scenario.robot.safety == SafetyConfig()
    config = pipeline_config(loaded.scenario)
    ideal = {"camera_fov_rad": 2.2, "camera_range_m": 5.0, "sonar_beam_rad": 0.0}  # its own
    assert config.safety == SafetyConfig(robot_radius_m=0.35).filled(**ideal)


def test_the_section_sets_the_zones() -> None:
    text = (
        b'name = "x"\n[robot.safety]\nstop_distance_m = 0.2\nslow_distance_m = 0.8\n'
        b"slow_speed_mps = 0.1\nmax_data_age_ms = 300\nrobot_radius_m = 0.4\n"
    )
    safety = pipeline_config(parse_scenario(text).scenario).safety
    assert (safety.stop_distance_m, safety.slow_distance_m, safety.slow_speed_mps) == (
        0.2,
        0.8,
        0.1,
    )
    assert (safety.max_data_age_ms, safety.robot_radius_m) == (300, 0.4)


@pytest.mark.parametrize(
    ("body", "pattern", "line"),
    [
        ("stop_distance_m = -0.1\n", r"safety stop_distance_m must be a non-negative number", 3),
        ("slow_distance_m = 0.05\n", r"the slow zone must contain the stop zone", 3),
        ("slow_speed_mps = 0.2\nmax_data_age_ms = -5\n", r"max_data_age_ms must be", 4),
        ("enabled = false\n", r"robot.safety.enabled: unknown field", 3),
        ("camera_range_m = -1.0\n", r"safety camera_range_m must be a non-negative", 3),
        ("camera_range_m = nan\n", r"camera_range_m \(m\): must be a finite number", 3),
    ],
)
def test_bad_safety_values_are_located_errors(body: str, pattern: str, line: int) -> None:
    text = f'name = "x"\n[robot.safety]\n{body}'.encode()
    with pytest.raises(ScenarioError, match=pattern) as caught:
        parse_scenario(text, source="s.toml")
    assert caught.value.line == line
    assert str(caught.value).startswith(f"s.toml:{line}:")


def test_the_supervisor_configuration_is_recorded_with_the_pipeline() -> None:
    loaded = parse_scenario(
        b'name = "x"\nduration_s = 0.1\n[robot.safety]\nslow_speed_mps = 0.15\n'
    )
    session = Session(loaded)
    recorded = msgspec.json.decode(session.metadata().configuration.pipeline)
    assert recorded["safety"]["slow_speed_mps"] == 0.15
    assert recorded["safety"]["robot_radius_m"] == 0.3


HUMANS = (
    b'[[humans]]\nid = "ada"\nx_m = 1.0\ny_m = 1.0\n'
    b'[[humans]]\nid = "dad"\nrole = "therapist"\nx_m = 2.0\ny_m = 1.0\nradius_m = 0.32\n'
    b"max_speed_mps = 1.4\n"
)


def test_left_out_the_sizes_and_speed_cover_the_scenarios_bodies() -> None:
    text = b'name = "x"\n[robot]\nradius_m = 0.35\n' + HUMANS
    safety = pipeline_config(parse_scenario(text).scenario).safety
    assert (safety.robot_radius_m, safety.human_radius_m, safety.human_speed_mps) == (
        0.35,
        0.32,
        1.4,
    )
    alone = pipeline_config(parse_scenario(b'name = "x"\n').scenario).safety
    assert (alone.human_radius_m, alone.human_speed_mps) == (0.25, 1.0), "never below these"


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (
            "human_radius_m = 0.3\n",
            "robot.safety.human_radius_m (m): 0.3 is below the radius_m 0.32 of human 'dad'",
        ),
        (
            "human_speed_mps = 1.0\n",
            "robot.safety.human_speed_mps (m/s): 1.0 is below the max_speed_mps 1.4 of human 'dad'",
        ),
        (
            "robot_radius_m = 0.2\n",
            "robot.safety.robot_radius_m (m): 0.2 is below the robot's radius_m 0.3",
        ),
    ],
)
def test_a_size_or_speed_below_the_scenarios_own_is_a_located_error(body, message) -> None:
    text = f'name = "x"\n[robot.safety]\n{body}'.encode() + HUMANS
    assert refused(text).startswith(f"s.toml:3:1: {message}: the supervisor")


def test_values_that_cover_the_scenario_are_kept() -> None:
    text = b'name = "x"\n[robot.safety]\nhuman_radius_m = 0.4\nhuman_speed_mps = 2.0\n' + HUMANS
    safety = pipeline_config(parse_scenario(text).scenario).safety
    assert (safety.human_radius_m, safety.human_speed_mps) == (0.4, 2.0)


NOISY = b'name = "x"\n[sensors]\nnoise_rho_m = 0.02\nnoise_theta_rad = 0.01\n'


def test_the_sensing_error_covers_three_times_the_sensors_noise() -> None:
    safety = pipeline_config(parse_scenario(NOISY).scenario).safety
    # 3 x (0.02 + 0.01 x (0.3 + 0.25 + 0.1)): the bearing's error at the stop zone's edge
    assert safety.sensing_error_m == 0.0795
    quiet = pipeline_config(parse_scenario(b'name = "x"\n').scenario).safety
    assert quiet.sensing_error_m == 0.02


def test_a_sensing_error_below_the_noise_is_a_located_error() -> None:
    text = NOISY.replace(b"[sensors]", b"[robot.safety]\nsensing_error_m = 0.05\n[sensors]")
    assert refused(text).startswith(
        "s.toml:3:1: robot.safety.sensing_error_m (m): 0.05 is below 3 times the sensors' noise"
        " (0.0795 m: noise_rho_m 0.02, and noise_theta_rad 0.01 at the stop zone's 0.65 m)"
    )


def test_a_noise_too_large_for_any_margin_is_a_located_error() -> None:
    text = b'name = "x"\n[sensors]\nnoise_rho_m = 1e308\nnoise_theta_rad = 1e308\n'
    assert refused(text).startswith(
        "s.toml:3:1: sensors.noise_rho_m (m): the sensors' noise (noise_rho_m 1e+308,"
        " noise_theta_rad 1e+308) is too large: 3 times it is no finite margin"
    )


@pytest.mark.parametrize(
    ("name", "alone", "scenario", "taken"),
    [
        ("max_status_age_ms", 2000, "[sensors]\nstatus_period_s = 1.5005", 3001),
        # a 1 Hz ring's echoes are a second old before the next scan: a 500 ms age would
        # cap their margins at half the walk (a child walking up behind a reversing robot
        # met it closing at 0.09 m/s inside the stop zone)
        ("max_data_age_ms", 500, "[sensors]\nsonar_scan_hz = 1", 1020),
        ("max_data_age_ms", 500, "tick_hz = 10\n[sensors]\nrate_hz = 2", 600),  # 500 + a tick
        ("max_scan_age_ms", 500, "[sensors]\nsonar_scan_hz = 3", 667),
        # 0.5 ** 20 < 1e-6 <= 0.5 ** 19: twenty scans at 5 Hz, or at 2 Hz
        ("echo_hold_ms", 2000, "[sensors]\ndropout_probability = 0.5", 4000),
        ("echo_hold_ms", 2000, "[sensors]\ndropout_probability = 0.5\nsonar_scan_hz = 2", 10_000),
        # the camera's 19 frames after the first that may all miss a child, at 10 Hz, at 4
        ("camera_miss_ms", 0, "[sensors]\ndropout_probability = 0.5", 1900),
        ("camera_miss_ms", 0, "[sensors]\ndropout_probability = 0.5\nrate_hz = 4", 4750),
        # the ring's 19 scans after the first that may all miss a child, at 5 Hz, at 2
        ("sonar_miss_ms", 0, "[sensors]\ndropout_probability = 0.5", 3800),
        ("sonar_miss_ms", 0, "[sensors]\ndropout_probability = 0.5\nsonar_scan_hz = 2", 9500),
    ],
)
def test_left_out_a_time_covers_what_the_scenarios_sensors_need(
    name, alone, scenario, taken
) -> None:
    """Never below the supervisor's own (``alone``), and at least what the sensors need."""
    default = pipeline_config(parse_scenario(b'name = "x"\n').scenario).safety
    assert getattr(default, name) == alone, "never below this"
    text = f'name = "x"\n{scenario}\n'.encode()
    assert getattr(pipeline_config(parse_scenario(text).scenario).safety, name) == taken


@pytest.mark.parametrize(
    ("setting", "sensors", "kept", "reason"),
    [
        (
            "max_status_age_ms = 1500",
            "status_period_s = 1.0",
            2000,
            "1500 is below two of the sensors' status_period_s 1.0 (2000 ms): the supervisor"
            " would take them for offline",
        ),
        (
            "max_scan_age_ms = 1500",
            "sonar_scan_hz = 1",
            2000,
            "1500 is below two of the sonar ring's scans (2000 ms at sonar_scan_hz 1): the"
            " supervisor would take the ring for down",
        ),
        (
            "max_data_age_ms = 1500",
            "rate_hz = 0.5",
            2020,
            "1500 is below the camera's frame and a tick (2020 ms at 0.5 Hz): readings would"
            " age past it",
        ),
        (
            "echo_hold_ms = 1500",
            "dropout_probability = 0.5",
            4000,
            "1500 is below 20 of the sonar ring's scans (4000 ms at sonar_scan_hz 5) that all"
            " miss a body with dropout_probability 0.5",
        ),
        (
            "camera_miss_ms = 1500",
            "dropout_probability = 0.5",
            1900,
            "1500 is below 19 of the camera's frames (1900 ms at rate_hz 10.0) that may all"
            " miss a child after the first with dropout_probability 0.5: with a sonar down the"
            " supervisor would count on seeing a child ahead sooner than it can",
        ),
        (
            "sonar_miss_ms = 1500",
            "dropout_probability = 0.5",
            3800,
            "1500 is below 19 of the sonar ring's scans (3800 ms at sonar_scan_hz 5) that"
            " may all miss a child after the first with dropout_probability 0.5: the"
            " supervisor would take a ring back for one that sees beside and behind the robot"
            " before it can",
        ),
    ],
)
def test_a_time_shorter_than_the_sensors_need_is_a_located_error(
    setting, sensors, kept, reason
) -> None:
    text = f'name = "x"\n[robot.safety]\n{setting}\n[sensors]\n{sensors}\n'.encode()
    name = setting.split()[0]
    assert refused(text).startswith(f"s.toml:3:1: robot.safety.{name} (ms): {reason}")
    enough = text.replace(b"1500", str(kept).encode())
    assert getattr(pipeline_config(parse_scenario(enough).scenario).safety, name) == kept


def test_a_ring_that_drops_detections_sees_a_person_later_a_located_warning() -> None:
    """Half the detections lost: the ring has seen a person stepping in only after 20
    scans, 4 s, in which the robot and the person close in by 6 m."""
    (warning,) = parse_scenario(
        b'name = "x"\n[sensors]\ndropout_probability = 0.5\n', source="s.toml"
    ).warnings
    assert "m closed in the 20 scans that see a body with dropout_probability 0.5" in str(warning)
    assert parse_scenario(b'name = "x"\n[sensors]\ndropout_probability = 0.02\n').warnings == ()


def test_left_out_the_cameras_view_is_the_scenarios_camera_even_when_narrow() -> None:
    narrow = b'name = "x"\n[sensors]\nfov_rad = 0.8\n'
    assert pipeline_config(parse_scenario(narrow).scenario).safety.camera_fov_rad == 0.8


@pytest.mark.parametrize(
    ("name", "own", "message"),
    [
        (
            "camera_fov_rad",
            "fov_rad",
            "(rad): 2.5 is wider than the camera's fov_rad 2.0: with the sonar ring down the"
            " supervisor would let the robot drive",
        ),
        (  # a child beyond it is never reported: their merged echo would be taken for a child's
            "camera_range_m",
            "range_m",
            "(m): 2.5 is beyond the camera's range_m 2.0: the supervisor would take a child"
            " beyond it",
        ),
    ],
)
def test_a_cameras_view_or_range_beyond_the_scenarios_camera_is_a_located_error(
    name: str, own: str, message: str
) -> None:
    text = f'name = "x"\n[robot.safety]\n{name} = 2.5\n[sensors]\n{own} = 2.0\n'.encode()
    assert refused(text).startswith(f"s.toml:3:1: robot.safety.{name} {message}")
    kept = text.replace(b"2.5", b"1.5")
    assert getattr(pipeline_config(parse_scenario(kept).scenario).safety, name) == 1.5


def test_left_out_the_cameras_range_is_the_scenarios_camera_even_when_short() -> None:
    short = b'name = "x"\n[sensors]\nrange_m = 2.0\n'
    assert pipeline_config(parse_scenario(short).scenario).safety.camera_range_m == 2.0


def test_left_out_a_merging_simulated_ring_reports_surfaces_and_the_ideal_ring_centres() -> None:
    """The simulator's merging ring reports each beam's nearest surface; its ideal ring,
    each body's centre (``sonar_reports_surface``; stated false, a merging ring's echo keeps
    its centre at its range)."""
    safety = pipeline_config(
        parse_scenario(b'name = "x"\n[sensors]\nsonar_beams = 12\n').scenario
    ).safety
    assert safety.sonar_reports_surface is True
    assert (
        pipeline_config(parse_scenario(b'name = "x"\n').scenario).safety.sonar_reports_surface
        is False
    )
    stated = (
        b'name = "x"\n[robot.safety]\nsonar_reports_surface = false\n[sensors]\nsonar_beams = 12\n'
    )
    assert pipeline_config(parse_scenario(stated).scenario).safety.sonar_reports_surface is False


def test_surfaces_stated_for_the_ideal_ring_are_a_located_error() -> None:
    """The ideal ring reports centres: taken for surfaces, each echo's centre would be kept a
    radius beyond the body's."""
    text = b'name = "x"\n[robot.safety]\nsonar_reports_surface = true\n'
    assert refused(text).startswith(
        "s.toml:3:1: robot.safety.sonar_reports_surface: true, but the ideal ring"
    )


def test_a_sonar_ring_too_short_for_the_supervisor_is_a_located_warning() -> None:
    assert parse_scenario(b'name = "x"\n').warnings == ()  # the 3 m ring
    # 0.3 + 0.25 + 0.1 + 0.02 + (0.5 + 1.0) x (1/5 + 1/50 s), then braking from 0.5 m/s at
    # 1 m/s2 (0.125 m) while the person walks on for 0.5 s (0.5 m): 1.625 m
    short = b'name = "x"\n[sensors]\nsonar_range_m = 1.62\n'
    (warning,) = parse_scenario(short, source="s.toml").warnings
    assert str(warning).startswith(
        "s.toml:3:1: sensors.sonar_range_m (m): the sonar ring reaches 1.62 m, less than the"
        " 1.625 m in which the safety supervisor can keep a person beside or behind"
    )
    assert "and 0.625 m while it brakes at max_accel_mps2 1.0)" in str(warning)
    assert parse_scenario(short.replace(b"1.62", b"1.63")).warnings == ()
    gentler = short.replace(b"1.62", b"1.63") + b"[robot]\nmax_accel_mps2 = 0.9\n"
    assert parse_scenario(gentler).warnings, "a base that brakes more gently needs a longer reach"
    slow_scan = short.replace(b"1.62", b"1.63") + b"sonar_scan_hz = 4\n"
    assert parse_scenario(slow_scan).warnings, "a slower scan needs a longer reach"


def test_a_camera_too_short_to_drive_on_with_the_ring_down_is_a_located_warning() -> None:
    """While a sonar is down only the camera sees ahead: one reporting people within less
    than 0.3 + 0.25 + 0.02 + 0.1 m, 0.5 s of a frame's wait at 0.5 m/s and a tick and
    braking from it (0.135 m), and a child's walk at 1 m/s meanwhile (1.02 m), 2.075 m,
    leaves the robot only turning then (a warning: the scenario runs, and drives while the
    ring is up)."""
    short = b'name = "x"\n[sensors]\nrange_m = 2.07\n'
    (warning,) = parse_scenario(short, source="s.toml").warnings
    assert str(warning).startswith(
        "s.toml:3:1: sensors.range_m (m): the camera reports people within 2.07 m, less than"
        " the 2.075 m in which the safety supervisor can stop the robot before a child"
        " walking at it"
    )
    assert str(warning).endswith("while a sonar is down the robot only turns")
    assert parse_scenario(short.replace(b"2.07", b"2.08")).warnings == ()
    slower = short + b"[robot]\nmax_speed_mps = 0.4\n"
    assert parse_scenario(slower).warnings == (), "a slower robot is seen in time"
    stated = b'name = "x"\n[robot.safety]\ncamera_range_m = 1.0\n'
    (warning,) = parse_scenario(stated, source="s.toml").warnings
    assert str(warning).startswith("s.toml:3:1: robot.safety.camera_range_m (m): the camera")


def test_a_camera_that_may_miss_a_child_needs_a_longer_range_with_the_ring_down() -> None:
    """Detections dropped at 0.02: the camera may miss a child on 3 frames after the first
    (300 ms at 10 Hz), in which the robot at 0.5 m/s and the child at 1 m/s close in by
    0.45 m more: 2.525 m, not 2.075 m, and the warning names the misses."""
    lossy = b'name = "x"\n[sensors]\ndropout_probability = 0.02\nrange_m = 2.52\n'
    (warning,) = parse_scenario(lossy, source="s.toml").warnings
    assert "less than the 2.525 m in which" in str(warning)
    assert "(max_frame_age_ms 500 and camera_miss_ms 300 of frames that miss a child)" in str(
        warning
    )
    assert parse_scenario(lossy.replace(b"2.52", b"2.53")).warnings == ()


def test_overrides_are_checked_for_the_sonar_rings_reach_too() -> None:
    loaded = parse_scenario(b'name = "x"\n[sensors]\nsonar_range_m = 1.63\n', source="s.toml")
    assert warnings_with(loaded, {}) == () == warnings_with(loaded, {"seed": "2"})
    (shortened,) = warnings_with(loaded, {"sensors.sonar_range_m": "0.5"})
    assert str(shortened).startswith(
        "<overrides>: sensors.sonar_range_m (m): the sonar ring reaches 0.5 m, less than the"
        " 1.625 m"
    )
    (faster,) = warnings_with(loaded, {"robot.max_speed_mps": "0.6"})  # the file's ring
    assert str(faster).startswith("s.toml:3:1: sensors.sonar_range_m (m): the sonar ring reaches")
    assert str(faster).endswith("(with robot.max_speed_mps=0.6)")


def test_a_real_robots_scenario_may_not_assume_less_of_people_than_the_supervisor() -> None:
    """Simulated humans justify a smaller or slower person; a real robot's (``oimi bridge``)
    people are not the scenario's: a child pushing at more than the 0 m/s set here would
    go uncounted while the ring is down."""
    ring = b'name = "x"\n[sensors]\nsonar_beams = 12\nfov_rad = 2.0\n'  # a real ring and camera
    text = ring + b"[robot.safety]\nhuman_speed_mps = 0.0\nhuman_radius_m = 0.2\n"
    loaded = parse_scenario(text, source="s.toml")  # a simulation with nobody in it: allowed
    with pytest.raises(ScenarioError, match=r"below the supervisor's own 1\.0 m/s") as caught:
        check_real_people(loaded)
    assert str(caught.value).startswith("s.toml:6:1: robot.safety.human_speed_mps (m/s): 0.0")
    assert [str(e) for e in caught.value.also] == [
        "s.toml:7:1: robot.safety.human_radius_m (m): 0.2 is below the supervisor's own"
        " 0.25 m: a real robot's people are not the scenario's, and a child may be larger or"
        " faster (left out, it is the larger of that and the scenario's humans')"
    ]
    check_real_people(parse_scenario(ring + b"[robot.safety]\nhuman_speed_mps = 1.5\n"))
    check_real_people(parse_scenario(ring))  # left out: the supervisor's own


def test_a_real_robots_scenario_must_say_how_wide_its_camera_sees() -> None:
    """With a sonar down the robot drives only inside the camera's view (narrowed for a
    child at its edge): the simulated camera's 2.2 rad, left out, may be wider than the
    lab's, and a child just outside the real view would be driven into (review of the
    narrowed view, H1). Either ``[sensors] fov_rad`` or ``[robot.safety] camera_fov_rad``."""
    ring = b'name = "x"\n[sensors]\nsonar_beams = 12\n'
    with pytest.raises(ScenarioError) as caught:
        check_real_people(parse_scenario(ring, source="s.toml"))
    assert str(caught.value).startswith("s.toml:2:1: sensors.fov_rad (rad): not set: give the")
    check_real_people(parse_scenario(ring + b"fov_rad = 1.2\n"))
    check_real_people(parse_scenario(ring + b"[robot.safety]\ncamera_fov_rad = 1.2\n"))


LOSSY = b"dropout_probability = 0.01\n"
"""Sensors that drop readings: the supervisor takes its misses from them (no warning)."""


def real_session(text: bytes, overrides: dict[str, str], warned: str) -> SafetyConfig:
    """The supervisor's configuration of a real robot's session (``oimi bridge``) of
    ``text`` (``s.toml``), which must apply ``overrides``, recorded as its variation, and
    warn once, starting with ``warned``."""
    loaded = parse_scenario(text, source="s.toml")
    assert real_robot_overrides(loaded) == overrides
    (warning,) = real_robot_warnings(loaded)
    assert str(warning).startswith(warned)
    session = Session(loaded, overrides=overrides)
    assert session.metadata().variation == overrides
    return session.config.safety


def test_a_real_robots_camera_range_left_out_is_the_supervisors_own_and_recorded() -> None:
    """The simulated camera's 5 m may reach farther than the lab's tracker: a child beyond
    its range is never reported, and the supervisor would take their echo, merged into a
    tracked child's, for that child. Left out, a real robot's session (``oimi bridge``,
    ``oimi replay BAG/``) takes the supervisor's own 3 m, with a warning (not a refusal: a
    shorter range keeps more echoes, stops, not collisions), as an override recorded as the
    session's variation, so that a redrive rebuilds the same supervisor."""
    ring = b'name = "x"\nduration_s = 0.1\n[sensors]\nsonar_beams = 12\nfov_rad = 1.2\n' + LOSSY
    surface = b"[robot.safety]\nsonar_reports_surface = true\n"  # (below)
    safety = real_session(
        ring + surface,
        {"robot.safety.camera_range_m": "3.0"},
        "s.toml:3:1: sensors.range_m (m): not set: the safety supervisor takes the robot's"
        " camera to report people within 3.0 m",
    )
    assert safety.camera_range_m == 3.0
    for stated in (ring + b"range_m = 4.0\n" + surface, ring + surface + b"camera_range_m = 4.0\n"):
        loaded = parse_scenario(stated)
        assert real_robot_overrides(loaded) == {} and real_robot_warnings(loaded) == ()
        assert pipeline_config(loaded.scenario).safety.camera_range_m == 4.0


def test_a_real_robots_ring_left_unsaid_is_taken_for_centres_with_a_warning() -> None:
    """The simulated merging ring reports surfaces, and a scenario that leaves
    ``sonar_reports_surface`` out takes that for its ring; a lab's driver may report a
    body's centre instead, whose echo, taken for a surface, would be kept a radius too far
    out. Left out, a real robot's session takes false (it covers either), with a warning,
    as an override recorded as the session's variation; stated either way, nothing."""
    ring = (
        b'name = "x"\nduration_s = 0.1\n[sensors]\nsonar_beams = 12\nfov_rad = 1.2\nrange_m = 4.0\n'
        + LOSSY
    )
    simulated = pipeline_config(parse_scenario(ring).scenario).safety
    assert simulated.sonar_reports_surface is True
    safety = real_session(
        ring,
        {"robot.safety.sonar_reports_surface": "false"},
        "s.toml: robot.safety.sonar_reports_surface: not set: the safety supervisor takes"
        " each echo's range for one that may be a body's centre",
    )
    assert safety.sonar_reports_surface is False
    for value in (b"true", b"false"):
        stated = parse_scenario(ring + b"[robot.safety]\nsonar_reports_surface = " + value + b"\n")
        assert real_robot_overrides(stated) == {} and real_robot_warnings(stated) == ()


def test_a_real_robots_sensors_taken_never_to_miss_a_child_are_a_warning() -> None:
    """A scenario whose sensors drop nothing leaves the supervisor taking a lab's person
    tracker and sonar ring never to miss a child (``camera_miss_ms``, ``sonar_miss_ms``
    0): a real robot's session warns of each left out; stated (0 too), or derived from a
    ``dropout_probability``, nothing."""
    ring = b'name = "x"\n[sensors]\nfov_rad = 1.2\nrange_m = 4.0\n'
    surface = b"[robot.safety]\nsonar_reports_surface = false\n"
    camera, sonar = real_robot_warnings(parse_scenario(ring + surface, source="s.toml"))
    assert str(camera).startswith(
        "s.toml:5:1: robot.safety.camera_miss_ms (ms): not set: the safety supervisor takes the"
        " lab's person tracker to report every child in its view on every frame"
    )
    assert str(sonar).startswith(
        "s.toml:5:1: robot.safety.sonar_miss_ms (ms): not set: the safety supervisor takes the"
        " lab's sonar ring to report every body on every scan"
    )
    stated = ring + surface + b"camera_miss_ms = 0\nsonar_miss_ms = 200\n"
    assert real_robot_warnings(parse_scenario(stated)) == ()
    assert real_robot_warnings(parse_scenario(ring + LOSSY + surface)) == ()
