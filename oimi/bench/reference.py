"""The reference loop: a deliberately naive Python program doing a recorded run's per-tick task.

It uses the libraries oimi uses and no cleverness. Per tick it decodes 3 JSON sensor
updates (a ``MapUpdate`` with its ``jsonmsg``) into a dict map, evaluates 10 conditions
compiled with lark into closures over that map, sets the robot's velocity from them and
steps its one pymunk body, then encodes 6 messages (the 3 updates, 2 rule decisions, 1
actuator command) with msgspec and writes them with ``mcap``'s ``Writer.add_message`` to
a zstd MCAP. Payloads are shaped like oimi's own messages, with changing numbers, so
they are about as large and as compressible as the real ones (a test compares them).
oimi's recorded run does more (the world, sensing, the rule chain, the reader, the map
and Foxglove views): the ratio of a run to this loop says what that costs.
"""

from __future__ import annotations

import math
import operator
import random
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO, Final

import lark
import msgspec
import pymunk
from mcap.writer import CompressionType, Writer

from oimi.bench.measure import timed

TICK_MS: Final = 20
INPUT_CYCLE_TICKS: Final = 500
"""Sensor inputs are generated for this many ticks and then repeat (10 s at 50 Hz)."""
PEOPLE: Final = ("Human/ada", "Human/ben", "Human/therapist")
ROBOT: Final = "Robot/oimi"
UPDATES, DECISIONS, COMMANDS = "/sensors/updates", "/rules/decisions", "/actuator/commands"
TOPICS: Final = (UPDATES, DECISIONS, COMMANDS)
PER_TICK: Final = {UPDATES: 3, DECISIONS: 2, COMMANDS: 1}
ARENA_M: Final = (7.0, 6.0)
SPEED_MPS: Final = 0.3
CONDITIONS: Final = {
    "ada_too_close": "Human/ada.poses.positionrho < 0.8",
    "ben_too_close": "Human/ben.poses.positionrho < 0.8",
    "therapist_near": "Human/therapist.poses.positionrho < 1.0",
    "too_fast": "Robot/oimi.odometry.speed > 0.45",
    "near_wall": "Robot/oimi.odometry.x < 0.5 or Robot/oimi.odometry.x > 6.5"
    " or Robot/oimi.odometry.y < 0.5 or Robot/oimi.odometry.y > 5.5",
    "ada_in_front": "Human/ada.poses.positionrho < 1.5 and Human/ada.poses.positiontheta > -0.5"
    " and Human/ada.poses.positiontheta < 0.5",
    "ben_in_front": "Human/ben.poses.positionrho < 1.5 and Human/ben.poses.positiontheta > -0.5"
    " and Human/ben.poses.positiontheta < 0.5",
    "children_gone": "Human/ada.poses.positionrho > 3.0 and Human/ben.poses.positionrho > 3.0",
    "attention_lost": "not (Human/ada.poses.positionrho < 2.0"
    " or Human/ben.poses.positionrho < 2.0)",
    "therapist_behind": "Human/therapist.poses.positiontheta > 2.5"
    " or Human/therapist.poses.positiontheta < -2.5",
}
RULECODES: Final = {name: code for code, name in enumerate(CONDITIONS)}
SAFETY: Final = ("ada_too_close", "ben_too_close", "therapist_near", "too_fast")
"""The first decision's conditions; any of them true stops the robot. The rest: engagement
(near a wall the robot heads for the middle of the room, otherwise for the nearest child)."""
_OPERATORS: Final = {
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
    "==": operator.eq,
    "!=": operator.ne,
}

Map = dict[str, dict[str, dict[str, Any]]]
Condition = Callable[[Map], bool]


class ReferenceReport(msgspec.Struct, frozen=True, kw_only=True):
    """What one reference loop did: its time, and everything it wrote (checked by the tests)."""

    ticks: int
    seconds: float
    messages: dict[str, int]
    payload_bytes: dict[str, int]
    file_bytes: int
    fired: dict[str, int]
    """Ticks at which each condition held."""
    final_position_m: tuple[float, float]


def compile_conditions(texts: dict[str, str] = CONDITIONS) -> dict[str, Condition]:
    """Each condition text parsed by lark and turned into a closure over a dict map."""
    parser = lark.Lark.open(
        str(Path(__file__).with_name("reference.lark")), start="expr", parser="lalr"
    )
    return {name: _closure(parser.parse(text)) for name, text in texts.items()}


def _closure(tree: lark.Tree) -> Condition:
    if tree.data == "comparison":
        objectid, attribute, field, op, number = (str(c) for c in tree.children)
        compare, value = _OPERATORS[op], float(number)

        def comparison(world: Map) -> bool:
            fields = world.get(objectid, {}).get(attribute)
            return fields is not None and compare(fields[field], value)

        return comparison
    parts = [_closure(child) for child in tree.children]
    if tree.data == "not_":
        return lambda world: not parts[0](world)
    left, right = parts
    if tree.data == "and_":
        return lambda world: left(world) and right(world)
    return lambda world: left(world) or right(world)


def sensor_inputs(seed: int = 11) -> list[list[bytes]]:
    """``INPUT_CYCLE_TICKS`` ticks of 3 encoded pose updates each, people moving smoothly."""
    rng = random.Random(seed)
    phases = [(rng.uniform(0, math.tau), rng.uniform(0, math.tau)) for _ in PEOPLE]
    encode = msgspec.json.encode
    cycle = []
    for tick in range(INPUT_CYCLE_TICKS):
        angle = math.tau * tick / INPUT_CYCLE_TICKS
        updates = []
        for index, objectid in enumerate(PEOPLE):
            rho_phase, theta_phase = phases[index]
            pose = {
                "positionrho": round(1.9 + 1.5 * math.sin(angle * (index + 1) + rho_phase), 4),
                "positiontheta": round(3.0 * math.sin(angle + theta_phase), 4),
                "positionchangetime": tick * TICK_MS,
            }
            update = {
                "objectid": objectid,
                "attributename": "poses",
                "policy": "A",
                "jsonmsg": encode(pose).decode(),
                "seq": tick * len(PEOPLE) + index,
            }
            updates.append(encode(update))
        cycle.append(updates)
    return cycle


class _Recorder:
    """Encodes dict messages and writes them with ``Writer.add_message``, counting what it wrote."""

    def __init__(self, stream: BinaryIO) -> None:
        self.writer = Writer(stream, compression=CompressionType.ZSTD, chunk_size=1024 * 1024)
        self.writer.start(profile="", library="oimi bench reference loop")
        self.channels = {}
        for topic in TOPICS:
            schema = self.writer.register_schema(
                name=topic, encoding="jsonschema", data=b'{"type":"object"}'
            )
            self.channels[topic] = self.writer.register_channel(
                topic=topic, message_encoding="json", schema_id=schema
            )
        self.messages = dict.fromkeys(TOPICS, 0)
        self.payload_bytes = dict.fromkeys(TOPICS, 0)

    def write(self, topic: str, time_ns: int, message: dict[str, Any]) -> None:
        data = msgspec.json.encode(message)
        self.writer.add_message(
            self.channels[topic],
            log_time=time_ns,
            publish_time=time_ns,
            data=data,
            sequence=self.messages[topic],
        )
        self.messages[topic] += 1
        self.payload_bytes[topic] += len(data)


def _room() -> tuple[pymunk.Space, pymunk.Body]:
    """A walled arena with the robot's body in its middle."""
    space = pymunk.Space()
    space.threads = 1
    width, height = ARENA_M
    corners = [(0, 0), (width, 0), (width, height), (0, height)]
    for start, end in zip(corners, [*corners[1:], corners[0]], strict=True):
        space.add(pymunk.Segment(space.static_body, start, end, 0.05))
    robot = pymunk.Body(10.0, pymunk.moment_for_circle(10.0, 0, 0.25))
    robot.position = (width / 2, height / 2)
    space.add(robot, pymunk.Circle(robot, 0.25))
    return space, robot


def reference_loop(ticks: int, path: Path) -> ReferenceReport:
    """Run the loop for ``ticks`` ticks writing ``path``. Timed: the loop and finishing the
    file; not timed: compiling the conditions, generating the inputs, building the room."""
    inputs = sensor_inputs()
    with path.open("wb") as stream:
        loop = _Loop(_Recorder(stream))

        def run() -> None:
            for tick in range(ticks):
                loop.tick(tick, inputs[tick % INPUT_CYCLE_TICKS])
            loop.out.writer.finish()

        seconds, _ = timed(run)
    x, y = loop.robot.position
    return ReferenceReport(
        ticks=ticks,
        seconds=seconds,
        messages=loop.out.messages,
        payload_bytes=loop.out.payload_bytes,
        file_bytes=path.stat().st_size,
        fired=loop.fired,
        final_position_m=(x, y),
    )


class _Loop:
    """The loop's state: the dict map, the compiled conditions, the room, the recorder."""

    def __init__(self, out: _Recorder) -> None:
        self.out = out
        self.conditions = compile_conditions()
        self.fired = dict.fromkeys(self.conditions, 0)
        self.space, self.robot = _room()
        self.world: Map = {}

    def tick(self, tick: int, raw_updates: list[bytes]) -> None:
        """Sense (decode into the map), think (conditions), act (velocity, step), record."""
        time_ms = tick * TICK_MS
        time_ns = time_ms * 1_000_000
        updates = []
        for raw in raw_updates:
            update = msgspec.json.decode(raw)
            fields = msgspec.json.decode(update["jsonmsg"])
            self.world.setdefault(update["objectid"], {})[update["attributename"]] = fields
            updates.append(update)
        results = {name: condition(self.world) for name, condition in self.conditions.items()}
        for name, result in results.items():
            self.fired[name] += result
        child = min(PEOPLE[:2], key=lambda h: self.world[h]["poses"]["positionrho"])
        theta = self.world[child]["poses"]["positiontheta"]
        if results["near_wall"]:
            x, y = self.robot.position
            theta = math.atan2(ARENA_M[1] / 2 - y, ARENA_M[0] / 2 - x)
        stop = any(results[name] for name in SAFETY)
        old = list(self.robot.velocity)
        speed = 0.0 if stop else SPEED_MPS
        velocity = [speed * math.cos(theta), speed * math.sin(theta)]
        self.robot.velocity = velocity
        self.space.step(TICK_MS / 1000)
        x, y = self.robot.position
        odometry = {"x": x, "y": y, "speed": abs(self.robot.velocity)}
        self.world[ROBOT] = {"odometry": odometry}
        for update in updates:
            update["tick"], update["time_ms"] = tick, time_ms
            self.out.write(UPDATES, time_ns, update)
        engagement = [name for name in results if name not in SAFETY]
        for rule, names in (("safety", SAFETY), ("engagement", engagement)):
            decision = {
                "tick": tick,
                "time_ms": time_ms,
                "rule": rule,
                "fired": any(results[name] for name in names),
                "conditions": [
                    {"rulecode": RULECODES[name], "result": results[name]} for name in names
                ],
                "bindings": {"?child": child},
                "changes": [{"path": "velocity", "old": old, "new": velocity}],
            }
            self.out.write(DECISIONS, time_ns, decision)
        led = [1.0, 0.2, 0.1] if stop else [0.2, 0.6, 1.0]
        command = {
            "tick": tick,
            "time_ms": time_ms,
            "commands": [
                _command("move", v_x=velocity[0], v_y=velocity[1], stop=stop),
                _command("led", r=led[0], g=led[1], b=led[2]),
                _command("audio", track_path="" if stop else "come_play.wav", stop=stop),
            ],
            "block": {
                "type": "instruction",
                "move": [{"v_x": velocity[0], "v_y": velocity[1], "v_theta": 0.0, "duration": 20}],
                "led": [{"r": led[0], "g": led[1], "b": led[2], "turnas": 1, "duration": 20}],
                "audioout": [] if stop else [{"track_path": "come_play.wav", "duration": 1500}],
            },
            "odometry": odometry,
        }
        self.out.write(COMMANDS, time_ns, command)


_CHANNEL_FIELDS: Final[dict[str, dict[str, Any]]] = {
    "move": {"v_x": 0.0, "v_y": 0.0, "v_theta": 0.0, "clamped": False, "requested": None},
    "led": {"r": 0.0, "g": 0.0, "b": 0.0, "clamped": False, "requested": None},
    "audio": {"track_path": ""},
}


def _command(channel: str, **fields: Any) -> dict[str, Any]:
    """One actuator command with every field of its channel, as oimi records it."""
    common = {"channel": channel, "source": "script", "stop": False}
    return common | _CHANNEL_FIELDS[channel] | fields
