"""The robot's clock against the session's: the times a remote robot's map updates carry
are moved from the clock of its odometry's stamps to the session's (``remote.RobotClock``),
never before 0 nor after the tick that takes them, and nothing else of an update changes."""

from __future__ import annotations

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds) is not installed")

from oimi.pipeline.sense.updates import INT_MAX

from oimi.ros2 import types
from oimi.ros2.remote import (
    CLOCK_WINDOW_MS,
    TIMES,
    RemoteSensors,
    clock_window_ms,
    odometry,
)


def update(objectid: str, attribute: str, jsonmsg: str) -> types.MapUpdate:
    return types.MapUpdate(objectid=objectid, attributename=attribute, policy="A", jsonmsg=jsonmsg)


def pose_at(time_ms: int) -> str:
    return f'{{"positionrho":1.5,"positiontheta":0.1,"positionchangetime":{time_ms}}}'


def test_map_update_times_move_from_the_robots_clock_to_the_sessions():
    """The robot started 100 s before the session: its readings' times are 100 s ahead of
    the session's (taken as they came, a frozen reading would look fresh for 100 s)."""
    sensors = RemoteSensors()
    sensors.receive(update("Human/c", "poses", pose_at(99_980)))
    (first,) = sensors.sample(None, tick=2, time_ms=40)  # no odometry yet: as it arrives
    assert first.jsonmsg == pose_at(40)
    for now_ms, robot_ms in ((60, 100_010), (80, 100_040), (100, 100_050)):  # the first late
        sensors.clock.odometry(
            odometry(time_ns=robot_ms * 1_000_000, pose=(0, 0, 0), velocity=(0, 0, 0)),
            now_ms=now_ms,
        )
    assert sensors.clock.offset_ms == 80 - 100_040  # the promptest delivery
    received = [
        update("Human/c", "poses", pose_at(100_010)),
        update("Human/c", "tracking", '{"permanencetime": 900, "appearanceon": 99100}'),
        update("RobotStatus", "touch", '{"touchtype": "C", "duration": 5, "startingtime": 100000}'),
        update("RobotStatus", "startingtime", "99000"),  # before the session: its start
        update("RobotStatus", "goalreached", '{"goalid": "g", "timestamp": 100030}'),
        update("Camera/front", "isonline", "s_true"),
        update("Human/c", "poses", pose_at(100_070)),  # delivered faster than any odometry
        update("Human/c", "poses", '{"positionrho": 1.5'),  # for the producer to refuse
        update("Human/c", "poses", '{"positionrho": 1, "positionchangetime": -5}'),  # likewise
        update("RobotStatus", "startingtime", "\u0663"),  # a digit, not an ASCII one
    ]
    for each in received:
        sensors.receive(each)
    moved = [u.jsonmsg for u in sensors.sample(None, tick=5, time_ms=100)]
    assert sensors.clock.offset_ms == 100 - 100_070, "a pose's own time bounds the offset too"
    assert moved == [
        pose_at(40),
        '{"permanencetime":900,"appearanceon":0}',
        '{"touchtype":"C","duration":5,"startingtime":30}',
        "0",
        '{"goalid":"g","timestamp":60}',
        "s_true",
        pose_at(100),
        '{"positionrho": 1.5',
        '{"positionrho": 1, "positionchangetime": -5}',
        "\u0663",
    ]


def pose_time_at(sensors: RemoteSensors, robot_ms: int, *, now_ms: int) -> int:
    """The session time a pose taken at ``robot_ms`` and received at ``now_ms`` gets."""
    sensors.receive(update("Human/c", "poses", pose_at(robot_ms)))
    (moved,) = sensors.sample(None, tick=now_ms // 20, time_ms=now_ms)
    return msgspec.json.decode(moved.jsonmsg)["positionchangetime"]


def test_a_robot_without_odometry_has_a_clock_from_its_poses():
    """No /odom: the poses' own times set the clock. A camera 20 s into its clock whose
    poses arrive 50 or 80 ms after they were taken: each keeps its age against the
    promptest delivery (0 or 30 ms; the very first is taken as it arrives)."""
    sensors = RemoteSensors()
    for now_ms in range(0, 2000, 100):
        late = 50 if now_ms % 200 else 80
        age = now_ms - pose_time_at(sensors, 20_000 + now_ms - late, now_ms=now_ms)
        assert age == (0 if now_ms == 0 else late - 50), now_ms


def test_a_rings_scan_time_moves_to_the_session_and_a_frozen_one_ages() -> None:
    """The ring's heartbeat (``scantime``, a bare time) is moved to the session's clock and
    sets it as a pose's time does (a robot with a ring and no /odom): a ring repeating its
    last scan time ages with the session, so the supervisor takes it for down."""
    sensors = RemoteSensors()

    def scan_time_at(robot_ms: int, now_ms: int) -> int:
        sensors.receive(update("Sonar/ring", "scantime", str(robot_ms)))
        (moved,) = sensors.sample(None, tick=now_ms // 20, time_ms=now_ms)
        return int(moved.jsonmsg)

    for now_ms in range(0, 1000, 200):  # scans at 5 Hz, 30 s into the robot's clock
        assert scan_time_at(30_000 + now_ms - 10, now_ms) == now_ms  # 10 ms late each
    assert sensors.clock.offset_ms == 10 - 30_000
    for now_ms in range(1000, 3000, 200):  # frozen on the scan of 800 ms
        assert scan_time_at(30_790, now_ms) == 800


def test_a_frozen_rings_scan_time_looks_older_than_any_scan_age_the_scenario_allows() -> None:
    """The clock's window covers the supervisor's scan age too: a ring repeating its last
    scan time, no /odom and nobody seen, looks older than ``max_scan_age_ms`` however
    long that is (with a window of the data age alone, 5 s, a scan age of 4.8 s or more
    let a frozen ring pass for a scanning one)."""
    from oimi.scenarios.loader import parse_scenario

    from oimi.ros2.remote import remote_sensors

    text = b'name = "x"\n[robot.safety]\nmax_scan_age_ms = 8000\n'
    sensors = remote_sensors(parse_scenario(text).scenario)
    ages = []
    for now_ms in range(0, 20_000, 200):
        sensors.receive(update("Sonar/ring", "scantime", "1000"))  # frozen at its first scan
        (moved,) = sensors.sample(None, tick=now_ms // 20, time_ms=now_ms)
        ages.append(now_ms - int(moved.jsonmsg))
    assert max(ages) > 8000


@pytest.mark.parametrize("max_data_age_ms", [500, 4000])
def test_a_sensor_frozen_on_an_old_reading_never_looks_fresh(max_data_age_ms):
    """Thesis-robot driver repeating its last pose with its old time, and no /odom: each
    repeat ages with the session's clock, and never looks younger than the clock's window
    (longer than the supervisor's max_data_age_ms, so it stays stale)."""
    sensors = RemoteSensors(max_data_age_ms=max_data_age_ms)
    window = clock_window_ms(max_data_age_ms)
    assert window > max_data_age_ms
    for now_ms in range(0, 3 * window, 100):
        age = now_ms - pose_time_at(sensors, 7_000, now_ms=now_ms)
        assert age == min(now_ms, window - 100), now_ms


def test_a_robot_whose_clock_jumps_back_is_followed_within_the_window():
    """A robot restarted at 10 s: its clock starts again from 0; its poses look as old as
    the session (stale: the safe side) until the samples of its old clock left the window."""
    sensors = RemoteSensors()
    for now_ms in range(0, 10_000, 100):
        pose_time_at(sensors, 60_000 + now_ms, now_ms=now_ms)
    for now_ms in range(10_000, 16_000, 100):
        age = now_ms - pose_time_at(sensors, now_ms - 10_000, now_ms=now_ms)
        assert age == (now_ms if now_ms < 9_900 + CLOCK_WINDOW_MS else 0), now_ms


time = st.integers(-(2**40), 2**64)
payload = st.dictionaries(
    st.sampled_from(["positionrho", "positionchangetime", "appearanceon", "startingtime", "x"]),
    st.one_of(time, st.floats(allow_nan=False, allow_infinity=False), st.text(max_size=3)),
    max_size=4,
)


@settings(derandomize=True, max_examples=300, deadline=None)
@given(
    attribute=st.sampled_from([*TIMES, "startingtime", "scantime", "isonline", "fps"]),
    jsonmsg=st.one_of(payload.map(lambda p: msgspec.json.encode(p).decode()), st.text(max_size=8)),
    stamp_ms=st.integers(0, 2**40),
    now_ms=st.integers(0, 2**30),
)
def test_only_valid_times_move_and_never_past_the_tick(attribute, jsonmsg, stamp_ms, now_ms):
    sensors = RemoteSensors()
    sensors.clock.odometry(
        odometry(time_ns=stamp_ms * 1_000_000, pose=(0, 0, 0), velocity=(0, 0, 0)),
        now_ms=now_ms,
    )
    sensors.receive(update("Human/c", attribute, jsonmsg))
    (out,) = sensors.sample(None, tick=now_ms // 20, time_ms=now_ms)
    assert (out.objectid, out.attributename, out.policy) == ("Human/c", attribute, "A")
    if out.jsonmsg == jsonmsg:
        return
    keys = TIMES.get(attribute, ())
    if not keys:  # a bare time
        assert jsonmsg.isascii() and jsonmsg.isdigit() and 0 <= int(jsonmsg) <= INT_MAX
        assert 0 <= int(out.jsonmsg) <= now_ms
        return
    before, after = msgspec.json.decode(jsonmsg), msgspec.json.decode(out.jsonmsg)
    assert list(before) == list(after)
    for key, value in after.items():
        if key in keys:
            assert 0 <= before[key] <= INT_MAX and 0 <= value <= now_ms
        else:
            assert value == before[key]
