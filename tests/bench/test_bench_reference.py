"""The reference loop does what it claims: 3 updates decoded, 10 conditions, 1 body, 6 writes."""

from __future__ import annotations

import math
from collections import Counter

import msgspec
import pytest
import zstandard
from mcap.reader import make_reader
from oimi.pipeline.events import Topic
from oimi.pipeline.sink import MemorySink

from oimi.bench.measure import bench_session
from oimi.bench.reference import (
    COMMANDS,
    CONDITIONS,
    DECISIONS,
    PER_TICK,
    RULECODES,
    SAFETY,
    SPEED_MPS,
    UPDATES,
    ReferenceReport,
    compile_conditions,
    reference_loop,
)

TICKS = 600


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> tuple[ReferenceReport, dict[str, list]]:
    path = tmp_path_factory.mktemp("reference") / "reference.mcap"
    report = reference_loop(TICKS, path)
    messages: dict[str, list] = {}
    with path.open("rb") as stream:
        reader = make_reader(stream)
        for _, channel, message in reader.iter_messages():
            messages.setdefault(channel.topic, []).append(message)
        stream.seek(0)
        compressions = {c.compression for c in make_reader(stream).get_summary().chunk_indexes}
    assert compressions == {"zstd"}
    assert path.stat().st_size == report.file_bytes
    return report, messages


def test_it_writes_three_updates_two_decisions_and_one_command_a_tick(written) -> None:
    report, messages = written
    for topic, per_tick in PER_TICK.items():
        assert len(messages[topic]) == report.messages[topic] == per_tick * TICKS, topic
        assert sum(len(m.data) for m in messages[topic]) == report.payload_bytes[topic], topic
        ticks = Counter(m.log_time // 20_000_000 for m in messages[topic])
        assert set(ticks.values()) == {per_tick} and len(ticks) == TICKS, topic


def test_its_decisions_are_the_conditions_on_the_map_its_updates_built(written) -> None:
    """Each decision agrees with hand-written predicates on the updates written so far and
    the odometry of the previous tick's command; its fired counts are the decisions'."""
    report, messages = written
    decode = msgspec.json.decode
    updates = [decode(m.data) for m in messages[UPDATES]]
    decisions = [decode(m.data) for m in messages[DECISIONS]]
    commands = [decode(m.data) for m in messages[COMMANDS]]
    poses: dict[str, dict] = {}
    odometry = None
    fired = dict.fromkeys(CONDITIONS, 0)
    codes = {code: name for name, code in RULECODES.items()}
    for tick in range(TICKS):
        for update in updates[3 * tick : 3 * tick + 3]:
            poses[update["objectid"].split("/")[1]] = decode(update["jsonmsg"])
        expected = by_hand(poses, odometry)
        for decision in decisions[2 * tick : 2 * tick + 2]:
            for item in decision["conditions"]:
                name = codes[item["rulecode"]]
                assert item["result"] == expected[name], (tick, name)
                fired[name] += item["result"]
        move = commands[tick]["commands"][0]
        stop = any(expected[name] for name in SAFETY)
        speed = math.hypot(move["v_x"], move["v_y"])
        assert speed == pytest.approx(0.0 if stop else SPEED_MPS), tick
        odometry = commands[tick]["odometry"]
    assert fired == report.fired
    assert len(report.fired) == len(CONDITIONS) == len(compile_conditions()) == 10
    assert sum(1 for count in report.fired.values() if count) >= 6, "most conditions do fire"
    assert report.final_position_m == (odometry["x"], odometry["y"])


def by_hand(poses: dict[str, dict], odometry: dict | None) -> dict[str, bool]:
    """The ten conditions of ``CONDITIONS``, written out in Python."""
    rho = {who: pose["positionrho"] for who, pose in poses.items()}
    theta = {who: pose["positiontheta"] for who, pose in poses.items()}
    return {
        "ada_too_close": rho["ada"] < 0.8,
        "ben_too_close": rho["ben"] < 0.8,
        "therapist_near": rho["therapist"] < 1.0,
        "too_fast": odometry is not None and odometry["speed"] > 0.45,
        "near_wall": odometry is not None
        and not (0.5 <= odometry["x"] <= 6.5 and 0.5 <= odometry["y"] <= 5.5),
        "ada_in_front": rho["ada"] < 1.5 and -0.5 < theta["ada"] < 0.5,
        "ben_in_front": rho["ben"] < 1.5 and -0.5 < theta["ben"] < 0.5,
        "children_gone": rho["ada"] > 3.0 and rho["ben"] > 3.0,
        "attention_lost": not (rho["ada"] < 2.0 or rho["ben"] < 2.0),
        "therapist_behind": abs(theta["therapist"]) > 2.5,
    }


def test_its_payloads_are_the_size_and_compressibility_of_oimis_own(written) -> None:
    """Sizes within a factor of two of a real busy_playroom run's messages of the same kind
    (one update; a tick's decisions; one command block), and compressing no better."""
    report, messages = written
    session = bench_session(TICKS)
    memory = MemorySink()
    session.sink.add(memory)
    session.run()
    encode = msgspec.json.encode
    real_updates = [encode(u) for e in memory.on(Topic.SENSOR_UPDATES) for u in e.updates]
    real = {
        UPDATES: real_updates,
        DECISIONS: [encode(e) for e in memory.on(Topic.RULE_DECISIONS)],
        COMMANDS: [encode(e) for e in memory.on(Topic.ACTUATOR_COMMANDS)],
    }
    ours = {
        UPDATES: report.payload_bytes[UPDATES] / report.messages[UPDATES],
        DECISIONS: report.payload_bytes[DECISIONS] / TICKS,
        COMMANDS: report.payload_bytes[COMMANDS] / report.messages[COMMANDS],
    }
    for topic, payloads in real.items():
        mean = sum(map(len, payloads)) / len(payloads)
        assert mean / 2 <= ours[topic] <= mean * 2, (topic, ours[topic], mean)
    compress = zstandard.ZstdCompressor().compress

    def ratio(payloads: list[bytes]) -> float:
        joined = b"".join(payloads)
        return len(compress(joined)) / len(joined)

    written_payloads = [m.data for topic in PER_TICK for m in messages[topic]]
    assert ratio(written_payloads) >= 0.8 * ratio([p for ps in real.values() for p in ps])
