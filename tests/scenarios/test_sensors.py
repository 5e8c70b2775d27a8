"""Simulated sensors: the world as the thesis's MapUpdates (tables 4.1, 4.2)."""

from __future__ import annotations

import math

import msgspec
import pytest
from oimi.pipeline.messages import ActuatorOutputs, MapUpdate, Policy
from oimi.scenarios.loader import parse_scenario
from oimi.scenarios.schema import FaultEvent, FaultMode, SensorKind, TouchEvent, TouchType
from oimi.scenarios.simulation.sensors import Schedule, Sensors, _json, _tracking
from oimi.scenarios.simulation.world import World, stream_rng

STOP = ActuatorOutputs()

ROOM = """
[robot]
x_m = 3.0
y_m = 2.5
theta_rad = {theta}
[sensors]
{sensors}
[world]
objects = [{{ id = "ball", x_m = 4.0, y_m = 2.5, istarget = true }}]
[[world.obstacles]]
id = "shelf"
kind = "shelf"
x_m = 3.0
y_m = 4.5
width_m = 1.0
height_m = 0.4
[[humans]]
id = "kid"
x_m = {kid_x}
y_m = {kid_y}
"""


def setup(
    *, theta: float = 0.0, kid: tuple[float, float] = (4.0, 3.5), sensors: str = "", seed: int = 1
) -> tuple[World, Sensors]:
    text = 'name = "sensors"\n' + ROOM.format(
        theta=theta, sensors=sensors, kid_x=kid[0], kid_y=kid[1]
    )
    scenario = parse_scenario(text.encode()).scenario
    world = World(scenario, stream_rng(seed, "world"))
    return world, Sensors(scenario.sensors, scenario, stream_rng(seed, "sensors"))


def tick(world: World, sensors: Sensors, number: int) -> list[MapUpdate]:
    world.step(STOP, tick=number)
    return sensors.sample(world, tick=number, time_ms=number * world.tick_ms)


def ticks(world: World, sensors: Sensors, count: int, start: int = 0) -> list[MapUpdate]:
    return [u for n in range(start, start + count) for u in tick(world, sensors, n)]


def of(updates: list[MapUpdate], objectid: str, attribute: str) -> list[MapUpdate]:
    return [u for u in updates if u.objectid == objectid and u.attributename == attribute]


def pose(update: MapUpdate) -> dict[str, float]:
    return msgspec.json.decode(update.jsonmsg)


def test_first_sample_reports_camera_sonar_and_start_status():
    world, sensors = setup()
    first = tick(world, sensors, 0)
    status = [(u.objectid, u.attributename, u.policy, u.jsonmsg) for u in first[:7]]
    assert status == [
        ("Camera/front", "isonline", Policy.R, "s_true"),
        ("Camera/front", "width", Policy.R, "640"),
        ("Camera/front", "height", Policy.R, "480"),
        ("Camera/front", "fps", Policy.R, "30"),
        ("Sonar/ring", "isonline", Policy.R, "s_true"),
        ("Sonar/ring", "scanfrequency", Policy.R, "5"),
        ("RobotStatus", "startingtime", Policy.R, "0"),
    ]
    assert not of(ticks(world, sensors, 10, 1), "Camera/front", "isonline")


def test_pose_is_relative_to_the_robot_position_and_heading():
    world, sensors = setup()
    update = of(tick(world, sensors, 0), "Human/kid", "poses")[0]
    assert update.policy is Policy.A
    assert update.jsonmsg == (
        '{"positionrho":1.4142,"positiontheta":0.7854,"positionchangetime":0}'
    )


def test_bearing_turns_with_the_robot_heading():
    world, sensors = setup(theta=math.pi / 2, kid=(4.5, 2.5), sensors="fov_rad = 3.5")
    # facing +y, the kid to the right
    content = pose(of(tick(world, sensors, 0), "Human/kid", "poses")[0])
    assert content["positionrho"] == pytest.approx(1.5)
    assert content["positiontheta"] == pytest.approx(-math.pi / 2, abs=1e-4)


def test_bearing_behind_is_wrapped_to_plus_pi():
    world, sensors = setup(kid=(1.0, 2.5), sensors="fov_rad = 6.3")
    content = pose(of(tick(world, sensors, 0), "Human/kid", "poses")[0])
    assert content["positiontheta"] == round(math.pi, 4)


@pytest.mark.parametrize(
    ("kid", "config", "why"),
    [
        ((1.5, 2.5), "", "behind the robot"),
        ((3.5, 4.5), "", "outside the field of view"),
        ((5.9, 2.5), "range_m = 2.5", "beyond the range"),
    ],
)
def test_entities_out_of_view_are_not_reported(kid, config, why):
    world, sensors = setup(kid=kid, sensors=config)
    updates = ticks(world, sensors, 20)
    assert not [u for u in updates if u.objectid == "Human/kid"], why
    assert of(updates, "Object/ball", "poses")


def test_camera_rate_is_honoured():
    world, sensors = setup(sensors="rate_hz = 10.0")  # 50 Hz ticks: every 5th tick
    sampled = [n for n in range(20) if of(tick(world, sensors, n), "Human/kid", "poses")]
    assert sampled == [0, 5, 10, 15]


def test_sonar_reports_obstacles_all_around_at_its_scan_rate():
    world, sensors = setup(theta=math.pi)  # shelf at 2 m, 90 degrees right of the heading
    scans = [n for n in range(25) if of(tick(world, sensors, n), "Obstacle/shelf", "poses")]
    assert scans == [0, 10, 20]


def test_first_sight_sends_the_fixed_attributes_once():
    world, sensors = setup()
    updates = ticks(world, sensors, 30)
    assert [u.jsonmsg for u in of(updates, "Object/ball", "istarget")] == ["s_true"]
    assert [u.jsonmsg for u in of(updates, "Object/ball", "category")] == ["ball"]
    assert [u.jsonmsg for u in of(updates, "Obstacle/shelf", "isfixed")] == ["s_true"]


def test_tracking_counts_the_time_in_view():
    world, sensors = setup()
    tracking = [pose(u) for u in of(ticks(world, sensors, 11), "Human/kid", "tracking")]
    assert tracking == [
        {"permanencetime": 0, "appearanceon": 0},
        {"permanencetime": 100, "appearanceon": 0},
        {"permanencetime": 200, "appearanceon": 0},
    ]


def rhos(seed: int, noise: str) -> list[float]:
    world, sensors = setup(sensors=noise, seed=seed)
    return [pose(u)["positionrho"] for u in of(ticks(world, sensors, 100), "Human/kid", "poses")]


def test_noise_is_seeded():
    noisy = "noise_rho_m = 0.05\nnoise_theta_rad = 0.02"
    assert rhos(3, noisy) == rhos(3, noisy)
    assert rhos(3, noisy) != rhos(4, noisy)
    assert len(set(rhos(3, noisy))) > 5
    assert set(rhos(3, "")) == {1.4142}
    assert max(abs(r - 1.4142) for r in rhos(3, noisy)) < 0.3


def test_dropouts_lose_detections():
    assert rhos(1, "dropout_probability = 1.0") == []
    assert 5 < len(rhos(1, "dropout_probability = 0.5")) < 15


def test_camera_offline_stops_entity_updates_until_back_online():
    world, sensors = setup()
    ticks(world, sensors, 10)
    sensors.fault(FaultEvent(at_s=0.2, sensor=SensorKind.CAMERA, mode=FaultMode.OFFLINE))
    offline = ticks(world, sensors, 20, 10)
    assert [u.jsonmsg for u in of(offline, "Camera/front", "isonline")] == ["s_false"]
    assert not [u for u in offline if u.objectid.startswith(("Human/", "Object/"))]
    assert of(offline, "Obstacle/shelf", "poses")  # the sonar still works
    sensors.fault(FaultEvent(at_s=0.6, sensor=SensorKind.CAMERA, mode=FaultMode.ONLINE))
    back = ticks(world, sensors, 10, 30)
    assert [u.jsonmsg for u in of(back, "Camera/front", "isonline")] == ["s_true"]
    assert pose(of(back, "Human/kid", "tracking")[0]) == {
        "permanencetime": 0,
        "appearanceon": 30 * 20,
    }


def test_a_silent_camera_says_nothing_not_even_its_status_until_back_online():
    world, sensors = setup()
    ticks(world, sensors, 10)
    sensors.fault(FaultEvent(at_s=0.2, sensor=SensorKind.CAMERA, mode=FaultMode.SILENT))
    silent = ticks(world, sensors, 150, 10)  # 3 s: three robot statuses
    assert len(of(silent, "RobotStatus", "speed")) == 3
    assert of(silent, "Sonar/ring", "isonline")  # the ring's status still comes
    assert not [u for u in silent if u.objectid.startswith(("Camera/", "Human/", "Object/"))]
    sensors.fault(FaultEvent(at_s=3.2, sensor=SensorKind.CAMERA, mode=FaultMode.ONLINE))
    back = ticks(world, sensors, 10, 160)
    assert [u.jsonmsg for u in of(back, "Camera/front", "isonline")] == ["s_true"]
    assert of(back, "Human/kid", "poses")


def test_frozen_sonar_repeats_its_last_reading():
    world, sensors = setup()
    last = of(ticks(world, sensors, 1), "Obstacle/shelf", "poses")[-1]
    sensors.fault(FaultEvent(at_s=0.1, sensor=SensorKind.SONAR, mode=FaultMode.FROZEN))
    repeated = of(ticks(world, sensors, 40, 1), "Obstacle/shelf", "poses")
    assert len(repeated) == 4
    assert {u.jsonmsg for u in repeated} == {last.jsonmsg}
    assert '"positionchangetime":0' in last.jsonmsg


def test_the_ring_sends_its_scan_time_with_every_scan_and_repeats_it_when_frozen():
    """The ring's heartbeat: ``scantime`` with each scan (5 Hz: every 200 ms), which a ring
    frozen while it saw nothing repeats, old, so the supervisor can tell it is down."""
    world, sensors = setup()
    scans = of(ticks(world, sensors, 30), "Sonar/ring", "scantime")
    assert [u.jsonmsg for u in scans] == ["0", "200", "400"]
    assert {u.policy for u in scans} == {Policy.R}
    sensors.fault(FaultEvent(at_s=0.6, sensor=SensorKind.SONAR, mode=FaultMode.FROZEN))
    frozen = of(ticks(world, sensors, 30, 30), "Sonar/ring", "scantime")
    assert [u.jsonmsg for u in frozen] == ["400", "400", "400"]


def test_touch_event_produces_the_tables_payload():
    world, sensors = setup()
    tick(world, sensors, 0)
    sensors.touch(
        TouchEvent(at_s=0.02, human="kid", touchtype=TouchType.C, duration_ms=800), time_ms=20
    )
    touch = of(tick(world, sensors, 1), "RobotStatus", "touch")
    assert [(u.policy, u.jsonmsg) for u in touch] == [
        (Policy.A, '{"touchtype":"C","duration":800,"startingtime":20}')
    ]


def test_a_human_bumping_into_the_robot_is_reported_as_a_touch_when_it_ends():
    text = """name = "bump"
[robot]
x_m = 3.0
y_m = 2.5
[[humans]]
id = "kid"
x_m = 1.0
y_m = 2.5
touchtype = "S"
behaviour = [{ kind = "approach", distance_m = 0.4 }, { at_s = 4.0, kind = "leave" }]
"""
    scenario = parse_scenario(text.encode()).scenario
    world = World(scenario, stream_rng(0, "world"))
    sensors = Sensors(scenario.sensors, scenario, stream_rng(0, "sensors"))
    updates = ticks(world, sensors, 250)
    touches = [pose(u) for u in of(updates, "RobotStatus", "touch")]
    assert len(touches) == 1
    assert touches[0]["touchtype"] == "S"
    assert touches[0]["startingtime"] + touches[0]["duration"] <= 4100
    assert touches[0]["duration"] > 1000


def test_robot_status_comes_every_second():
    world, sensors = setup()
    updates = []
    for number in range(120):
        world.step(ActuatorOutputs(v_x=0.5), tick=number)
        updates += sensors.sample(world, tick=number, time_ms=number * 20)
    speeds = [pose(u) for u in of(updates, "RobotStatus", "speed")]
    # each the mean velocity since the one before (the first: nothing yet)
    assert [(s["startingtime"], s["duration"]) for s in speeds] == [(0, 0), (0, 1000), (1000, 1000)]
    assert speeds[2] == {  # the ball it reaches slows it a hair
        "xspeed": 0.4997,
        "yspeed": 0.0,
        "thetaspeed": 0.0,
        "duration": 1000,
        "startingtime": 1000,
    }
    assert 0.3 < speeds[1]["xspeed"] < 0.45  # the first second ramps up (at 1 m/s²)
    battery = [u.jsonmsg for u in of(updates, "RobotStatus", "batterytimeleft")]
    assert battery == ["3600000", "3599000", "3598000"]
    assert [u.jsonmsg for u in of(updates, "RobotStatus", "elapsedtime")] == ["0", "1000", "2000"]


def test_with_the_ring_down_the_speed_comes_every_100_ms():
    """The ring offline (or frozen, or silent): the speed every 100 ms, each interval
    starting where the last ended (the supervisor counts a push over the time no report
    covers); the battery and elapsed time still every second; back online, every second."""
    world, sensors = setup()
    ticks(world, sensors, 5)
    sensors.fault(FaultEvent(at_s=0.1, sensor=SensorKind.SONAR, mode=FaultMode.OFFLINE))
    down = ticks(world, sensors, 50, 5)  # 0.1 s to 1.1 s
    speeds = [pose(u) for u in of(down, "RobotStatus", "speed")]
    starts = [s["startingtime"] for s in speeds]
    assert starts == [0, *range(100, 1000, 100)]
    ends = [s["startingtime"] + s["duration"] for s in speeds]
    assert ends[:-1] == starts[1:]
    assert len(of(down, "RobotStatus", "batterytimeleft")) == 1
    sensors.fault(FaultEvent(at_s=1.1, sensor=SensorKind.SONAR, mode=FaultMode.ONLINE))
    back = ticks(world, sensors, 100, 55)  # 1.1 s to 3.1 s
    assert [pose(u)["startingtime"] for u in of(back, "RobotStatus", "speed")] == [1000, 2000]


def test_seq_numbers_increase_from_one():
    world, sensors = setup(sensors="noise_rho_m = 0.01\ndropout_probability = 0.3")
    seqs = [u.seq for u in ticks(world, sensors, 100)]
    assert seqs == list(range(1, len(seqs) + 1))


def test_every_update_decodes_with_the_map_producers_table():
    from oimi.pipeline.sense.updates import decode_update

    world, sensors = setup(sensors="noise_rho_m = 0.05\nfov_rad = 6.3", theta=2.0)
    sensors.touch(TouchEvent(at_s=0.0, human="kid", touchtype=TouchType.H), time_ms=0)
    sensors.fault(FaultEvent(at_s=0.0, sensor=SensorKind.SONAR, mode=FaultMode.OFFLINE))
    updates = ticks(world, sensors, 60)
    assert {u.attributename for u in updates} >= {"poses", "tracking", "touch", "speed"}
    for update in updates:
        decode_update(update)


def test_led_colours_and_tracks_are_reported_as_the_robots_history_when_they_end():
    world, sensors = setup()
    lit = ActuatorOutputs(led=(0.0, 0.5, 1.0), audio="song.wav")
    world.step(lit, tick=0)
    assert of(sensors.sample(world, tick=0, time_ms=0), "RobotStatus", "led") == []
    world.step(lit, tick=1)
    assert of(sensors.sample(world, tick=1, time_ms=20), "RobotStatus", "led") == []
    world.step(STOP, tick=2)
    updates = sensors.sample(world, tick=2, time_ms=40)
    assert [(u.policy, u.jsonmsg) for u in of(updates, "RobotStatus", "led")] == [
        (Policy.A, '{"r":0.0,"g":0.5,"b":1.0,"frequency":0,"duration":40,"startingtime":0}')
    ]
    assert [u.jsonmsg for u in of(updates, "RobotStatus", "audioout")] == [
        '{"duration":40,"startingtime":0,"trackpath":"song.wav"}'
    ]
    world.step(STOP, tick=3)
    assert of(sensors.sample(world, tick=3, time_ms=60), "RobotStatus", "led") == []


# ----------------------------------------------------- schedules (defence in depth)


@pytest.mark.parametrize("period_ms", [0.0, -20.0, math.inf, math.nan])
def test_a_schedule_refuses_a_period_that_would_never_advance(period_ms):
    with pytest.raises(ValueError, match="must be positive and finite"):
        Schedule(period_ms)


def test_a_sensor_at_rate_zero_is_refused_not_divided_by():
    scenario = parse_scenario(b'name = "x"\n').scenario
    bad = msgspec.structs.replace(scenario.sensors, rate_hz=0.0)  # past the loader's ranges
    with pytest.raises(ValueError, match="got nan ms"):
        Sensors(bad, scenario, stream_rng(0, "sensors"))


def test_a_tiny_period_is_due_once_a_tick_and_never_hangs():
    schedule = Schedule(1e-300)
    assert [schedule.due(t) for t in (0, 0, 20, 20, 40)] == [True, False, True, False, True]


def test_a_schedule_keeps_its_phase():
    schedule = Schedule(30.0)  # due at 0, 30, 60, 90 ... sampled every 20 ms
    assert [t for t in range(0, 200, 20) if schedule.due(t)] == [0, 40, 60, 100, 120, 160, 180]


def test_sonar_reports_a_person_behind_the_robot_as_an_echo_that_is_not_fixed():
    world, sensors = setup(kid=(2.0, 2.5))  # 1 m behind: out of the front camera's view
    updates = ticks(world, sensors, 25)
    assert not [u for u in updates if u.objectid.startswith("Human/")]
    assert [u.jsonmsg for u in of(updates, "Obstacle/echo-0", "isfixed")] == ["s_false"]
    rho = msgspec.json.decode(of(updates, "Obstacle/echo-0", "poses")[-1].jsonmsg)["positionrho"]
    assert rho == pytest.approx(1.0)
    assert [u.jsonmsg for u in of(updates, "Obstacle/shelf", "isfixed")] == ["s_true"]


def test_an_echo_id_is_never_an_obstacle_id():
    text = 'name = "echoes"\n' + ROOM.format(theta=0.0, sensors="", kid_x=2.0, kid_y=2.5)
    text = text.replace('id = "shelf"', 'id = "echo-0"')
    scenario = parse_scenario(text.encode()).scenario
    world = World(scenario, stream_rng(1, "world"))
    sensors = Sensors(scenario.sensors, scenario, stream_rng(1, "sensors"))
    updates = ticks(world, sensors, 25)
    assert [u.jsonmsg for u in of(updates, "Obstacle/echo-0", "isfixed")] == ["s_true"]
    assert [u.jsonmsg for u in of(updates, "Obstacle/echo-0_", "isfixed")] == ["s_false"]


@pytest.mark.parametrize(("time_ms", "appeared_ms"), [(0, 0), (1500, 200), (-20, 7_000_000_000)])
def test_a_tracks_record_is_written_as_the_other_records_are(time_ms, appeared_ms) -> None:
    """``_tracking`` writes its two integers by hand (the hot path): the bytes must stay
    those the shared encoder writes for the same record."""
    record = {"permanencetime": time_ms - appeared_ms, "appearanceon": appeared_ms}
    assert _tracking(time_ms, appeared_ms) == _json(record)
