"""rosbag2 both ways: a session exported as a rosbag2, and the pipeline driven over one.

``export_rosbag`` writes a recording as a rosbag2 folder (MCAP storage, zstd chunks,
``ros2msg`` definitions, CDR messages encoded by ``oimi.ros2.types``), readable by
``ros2 bag`` and by ``rosbags``. Joystick states are repeated every
``JOY_REPEAT_MS`` while the safety lock is held, as ``joy_node`` repeats them, so a
bag replayed through the dead-man's heartbeat keeps the lock as it was held.

``replay_rosbag`` drives a scenario's pipeline over a rosbag2's ``oimi_msgs/MapUpdate``,
``sensor_msgs/Joy`` (through the live session's joystick guard, with the bag's time
as its clock), ``nav_msgs/Odometry`` and, when present, ``/oimi/operator_commands``
(then the scenario's own schedule is not used). Message ``t`` enters at tick
``(t - start) // tick``. The result is an ordinary oimi recording, which itself
replays with ``oimi replay --mode redrive``.
"""

from __future__ import annotations

import importlib.resources
import math
from collections import defaultdict
from collections.abc import Iterator
from pathlib import Path
from typing import Final

import msgspec
from rosbags.rosbag2 import Reader, Writer
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode, StoragePlugin
from rosbags.rosbag2.errors import ReaderError, WriterError
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from oimi.live.inputs import JoystickGuard, Pad
from oimi.pipeline.errors import LocatedError
from oimi.pipeline.events import (
    ActuatorCommands,
    JoystickInput,
    MapDelta,
    OperatorCommands,
    RuleChainState,
    SensorUpdates,
    Topic,
    WorldState,
)
from oimi.pipeline.messages import MoveCommand, ScriptInfo
from oimi.pipeline.operator.commands import OperatorCommand
from oimi.pipeline.sink import NS_PER_MS
from oimi.recorder.metadata import BAG_ROLE, RecordingMetadata, Ros2Record
from oimi.recorder.reader import open_recording
from oimi.ros2 import topics, types
from oimi.ros2.bridge import rule_message, script_info
from oimi.ros2.joy import joy_of, pad_of
from oimi.ros2.remote import RemoteBody, odometry, remote_sensors
from oimi.ros2.topics import RosTopic
from oimi.scenarios.loader import LoadedScenario
from oimi.scenarios.real_robot import real_robot_overrides
from oimi.scenarios.session.recording import recorded
from oimi.scenarios.session.runner import RunResult, Session
from oimi.scenarios.session.watchdog import watching

BAG_VERSION: Final = 9
JOY_REPEAT_MS: Final = 100
"""How often an exported held pad state is repeated (``joy_node`` repeats at 20 Hz)."""
BAG_OWNER: Final = "rosbag2:/joy"


class BagError(LocatedError):
    """A rosbag2 that cannot be written or read as asked."""


def typestore() -> Typestore:
    """ROS 2 Humble's standard types plus ``oimi_msgs``, from ``ros2/oimi_msgs/msg``."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    folder = importlib.resources.files("oimi.ros2").joinpath("msg")
    for name in types.OIMI_MSGS:
        text = folder.joinpath(f"{name}.msg").read_text()
        store.register(get_types_from_msg(text, f"oimi_msgs/msg/{name}"))
    return store


# ----------------------------------------------------------------------------- export


EXPORTED: Final = (
    topics.MAP_UPDATES,
    topics.JOY,
    topics.OPERATOR_COMMANDS,
    topics.ODOM,
    topics.CMD_VEL,
    topics.LED,
    topics.AUDIO,
    topics.SCRIPT_INFO,
    topics.RULE_MESSAGES,
    topics.RULE_DECISIONS,
)
"""The bag's topics, in this order."""


def _converted(source: Path) -> Iterator[tuple[int, RosTopic, object]]:
    """The recording's messages as ROS 2 messages: (time ns, topic, sample)."""
    recording = open_recording(source)
    info: types.ScriptInfo | None = None
    shown: tuple[object, object] | None = None
    held: tuple[int, Pad] | None = None  # a locked pad state and when it was last sent
    for message in recording.iter_messages():
        t = message.time_ns
        while held is not None and held[0] + JOY_REPEAT_MS * NS_PER_MS < t:
            held = (held[0] + JOY_REPEAT_MS * NS_PER_MS, held[1])
            yield held[0], topics.JOY, joy_of(held[1], time_ns=held[0])
        event = message.decoded()
        match event:
            case SensorUpdates():
                for u in event.updates:
                    yield (
                        t,
                        topics.MAP_UPDATES,
                        types.MapUpdate(
                            objectid=u.objectid,
                            attributename=u.attributename,
                            policy=str(u.policy),
                            jsonmsg=u.jsonmsg,
                        ),
                    )
            case JoystickInput():
                pad = event.pad
                held = (t, pad) if pad.locked else None
                yield t, topics.JOY, joy_of(pad, time_ns=t)
            case OperatorCommands():
                for command in event.commands:
                    text = msgspec.json.encode(command).decode()
                    yield t, topics.OPERATOR_COMMANDS, types.String(data=text)
            case WorldState():
                robot = event.robot
                pose = (robot.x_m, robot.y_m, robot.theta_rad)
                yield t, topics.ODOM, odometry(time_ns=t, pose=pose, velocity=_body(event))
                if (event.led, event.audio) != shown:
                    shown = (event.led, event.audio)
                    r, g, b = event.led
                    on = 1.0 if any(event.led) else 0.0
                    yield t, topics.LED, types.ColorRGBA(r=r, g=g, b=b, a=on)
                    yield t, topics.AUDIO, types.String(data=event.audio)
            case ActuatorCommands():
                for command in event.commands:
                    if isinstance(command, MoveCommand):
                        yield (
                            t,
                            topics.CMD_VEL,
                            types.Twist(
                                linear=types.Vector3(x=command.v_x, y=command.v_y),
                                angular=types.Vector3(z=command.v_theta),
                            ),
                        )
            case MapDelta() if event.scriptinfo:  # the script's part changed
                now = script_info(msgspec.json.decode(event.scriptinfo, type=ScriptInfo))
                if now != info:
                    info = now
                    yield t, topics.SCRIPT_INFO, now
            case RuleChainState():
                for rule in event.applied:
                    yield t, topics.RULE_MESSAGES, rule_message(rule)
        if message.topic is Topic.RULE_DECISIONS:
            yield t, topics.RULE_DECISIONS, types.String(data=message.payload_bytes.decode())


def _body(state: WorldState) -> tuple[float, float, float]:
    """The robot's velocity in its own frame (forward, leftward, turn)."""
    robot = state.robot
    cos, sin = math.cos(robot.theta_rad), math.sin(robot.theta_rad)
    return (
        cos * robot.vx_mps + sin * robot.vy_mps,
        -sin * robot.vx_mps + cos * robot.vy_mps,
        robot.omega_radps,
    )


def export_rosbag(source: Path, out: Path) -> dict[str, int]:
    """Write the recording ``source`` as the rosbag2 folder ``out`` (which must not exist);
    the messages written per topic."""
    store = typestore()
    counts = {topic.name: 0 for topic in EXPORTED}
    try:
        writer = Writer(out, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
    except WriterError as error:  # its message starts with the path: say it once
        raise BagError(str(error).removeprefix(f"{out} "), source=str(out)) from None
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    writer.set_custom_data("oimi.source", source.name)
    entries = sorted(_converted(source), key=lambda entry: entry[0])
    with writer:
        connections = {
            topic.name: writer.add_connection(topic.name, topic.type_name, typestore=store)
            for topic in EXPORTED
        }
        for time_ns, topic, sample in entries:
            writer.write(connections[topic.name], time_ns, types.encode(sample))  # type: ignore[arg-type]
            counts[topic.name] += 1
    return counts


# ----------------------------------------------------------------------------- replay


class _Inputs(msgspec.Struct):
    """What a bag holds for one tick."""

    updates: list[types.MapUpdate] = []
    joys: list[tuple[float, types.Joy]] = []
    odometry: list[types.Odometry] = []
    commands: list[OperatorCommand] = []


INPUT_TYPES: Final = {
    "oimi_msgs/msg/MapUpdate": "updates",
    "sensor_msgs/msg/Joy": "joys",
    "nav_msgs/msg/Odometry": "odometry",
}


def read_inputs(bag: Path, *, tick_ms: int) -> tuple[dict[int, _Inputs], int, bool]:
    """The bag's inputs by tick, the number of ticks, and whether it holds operator
    commands. Raises ``BagError`` naming the bag (and the message) that cannot be read."""
    by_tick: dict[int, _Inputs] = defaultdict(_Inputs)
    tick_ns = tick_ms * NS_PER_MS
    has_commands = False
    last = -1
    try:
        with Reader(bag) as reader:
            start = reader.start_time
            wanted = [
                c
                for c in reader.connections
                if c.msgtype in INPUT_TYPES or c.topic == topics.OPERATOR_COMMANDS.name
            ]
            for index, (connection, time_ns, raw) in enumerate(reader.messages(wanted)):
                tick = (time_ns - start) // tick_ns
                last = max(last, tick)
                inputs = by_tick[tick]
                where = f"{bag}: {connection.topic} message {index}"
                field = INPUT_TYPES.get(connection.msgtype)
                if field is None:  # the operator's commands (oimi's own export)
                    has_commands = True
                    text = _decode(types.String, raw, where).data  # type: ignore[attr-defined]
                    try:
                        inputs.commands.append(msgspec.json.decode(text, type=OperatorCommand))
                    except msgspec.ValidationError as error:
                        raise BagError(f"not an operator command: {error}", source=where) from None
                    continue
                kind = types.ROS_TYPES[connection.msgtype]
                sample = _decode(kind, raw, where)
                if field == "joys":
                    inputs.joys.append(((time_ns - start) / 1e9, sample))  # type: ignore[arg-type]
                else:
                    getattr(inputs, field).append(sample)
    except (ReaderError, OSError) as error:  # no metadata.yaml, a damaged file...
        raise BagError(f"not a readable rosbag2: {error}", source=str(bag)) from None
    return by_tick, last + 1, has_commands


def _decode(kind: type, raw: bytes | memoryview, where: str) -> object:
    try:
        return types.decode(kind, raw)
    except Exception as error:  # a definition other than ours: the CDR does not fit
        raise BagError(f"cannot decode as {types.ros_name(kind)}: {error}", source=where) from None


class BagSession(Session):
    """A session driven over a rosbag2's inputs: its recording says so (``ros2`` record,
    role ``bag``), so that its people's expectations are not judged again and it is not
    rerun (``oimi.replaying``)."""

    def metadata(self) -> RecordingMetadata:
        return msgspec.structs.replace(
            super().metadata(),
            ros2=Ros2Record(role=BAG_ROLE, replay="redrive: the bag's inputs are recorded inputs"),
        )


def replay_rosbag(
    bag: Path,
    loaded: LoadedScenario,
    *,
    output: Path | None,
    seed: int | None = None,
    overwrite: bool = False,
) -> tuple[RunResult, int, list[str]]:
    """Drive the scenario's pipeline over the bag's inputs, recording to ``output`` (an
    existing file replaced only with ``overwrite``); the session's result, the number of
    ticks run and notes on refused inputs."""
    inputs, ticks, has_commands = read_inputs(bag, tick_ms=loaded.scenario.tick_ms)
    body = RemoteBody(loaded.scenario.robot.radius_m)
    sensors = remote_sensors(loaded.scenario)
    session = BagSession(
        loaded,
        seed=seed,
        autostart=not has_commands,
        world=body,
        sensors=sensors,
        overrides=real_robot_overrides(loaded),  # the bag's readings are a real camera's
    )
    if has_commands:
        session.schedule.clear()  # the bag's commands include the scenario's own
    guard = JoystickGuard()
    released: list[str] = []
    with recorded(session, mcap=output, rrd=None, overwrite=overwrite), watching() as watchdog:
        for tick in range(ticks):
            now = inputs.pop(tick, _Inputs())
            for update in now.updates:
                sensors.receive(update)
            time_ms = tick * session.tick_ms
            for odom in now.odometry:
                body.odometry = odom
                sensors.clock.odometry(odom, now_ms=time_ms)
            for at_s, joy in now.joys:
                guard.receive(BAG_OWNER, pad_of(joy), now_s=at_s)
            taken = guard.take(now_s=time_ms / 1000)
            joystick = None
            if taken is not None:
                joystick = taken.pad.at(tick=tick, time_ms=time_ms, release=taken.release)
                if taken.release is not None:
                    released.append(f"tick {tick}: safety lock released ({taken.release})")
            session.step(tick, commands=now.commands, joystick=joystick)
            watchdog.feed()
    return session.result(), ticks, [*sensors.refused, *released]
