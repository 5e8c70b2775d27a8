"""``oimi bridge``: the pipeline as a ROS 2 participant, run as a live session.

The live server (``oimi/live/server.py``) paces the session to the wall clock and
serves the operator's App Interface and console as in ``oimi serve``. Each tick the
bridge's session takes what arrived over DDS: map updates become the tick's sensor
updates, ``Joy`` states go to the live session's joystick guard (the same dead-man
rules as the console's pad: the lock is released when the pad falls silent for
0.5 s), odometry becomes the recorded world state. After the tick it publishes the
actuator's outputs (``cmd_vel`` every tick; LED and audio when they change) and,
through a sink, the script's progress and the rules' messages and decisions.

Every input enters the recording at the tick that used it, exactly as in a live
session, so the recording replays with ``oimi replay --mode redrive``. When the
bridge stops, it commands the robot to stand still.
"""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import Callable, Iterable, Iterator
from typing import Final

import msgspec
from cyclonedds.util import duration

from oimi.cmd_check import report_warnings
from oimi.live.app import Served, note, serve
from oimi.live.inputs import JoystickGuard
from oimi.live.server import LiveServer
from oimi.live.session import LiveSession
from oimi.pipeline.events import (
    Event,
    JoystickInput,
    MapDelta,
    RuleChainState,
    RuleDecisions,
    Topic,
)
from oimi.pipeline.messages import ActuatorOutputs, RuleMessage, ScriptInfo, WorldMap
from oimi.pipeline.operator.commands import OperatorCommand
from oimi.recorder.metadata import RecordingMetadata, Ros2Record
from oimi.ros2 import topics, types
from oimi.ros2.dds import DEEP, Node, take_all
from oimi.ros2.joy import pad_of
from oimi.ros2.network import network_from_args
from oimi.ros2.remote import RemoteBody, outputs_message, remote_sensors
from oimi.scenarios.loader import LoadedScenario
from oimi.scenarios.real_robot import (
    check_real_people,
    real_robot_overrides,
    real_robot_warnings,
)

JOY_OWNER: Final = "ros2:/joy"
"""The joystick guard's owner for pad states that arrive over DDS."""
STOP_ACK_MS: Final = 200
"""How long the stopping bridge waits for the robot to acknowledge the stop."""


class ProgressPublisher:
    """A sink that publishes the script's progress (the map's ``scriptinfo`` when it
    changes), the rule messages applied and the rules' decisions on their ROS 2 topics."""

    def __init__(self, node: Node, world_map: WorldMap) -> None:
        self.map = world_map
        self._script = node.writer(topics.SCRIPT_INFO)
        self._rules = node.writer(topics.RULE_MESSAGES)
        self._decisions = node.writer(topics.RULE_DECISIONS)
        self._info: types.ScriptInfo | None = None

    def record(self, topic: Topic, time_ns: int, message: Event) -> None:
        match message:
            case MapDelta() if message.scriptinfo:  # the script's part changed
                info = script_info(self.map.scriptinfo)
                if info != self._info:
                    self._info = info
                    self._script.write(info)
            case RuleChainState():
                for rule in message.applied:
                    self._rules.write(rule_message(rule))
            case RuleDecisions():
                self._decisions.write(types.String(data=msgspec.json.encode(message).decode()))


def rule_message(rule: RuleMessage) -> types.RuleMessage:
    """An alfa/omega message as ``oimi_msgs/RuleMessage``."""
    return types.RuleMessage(
        rulecode=rule.rulecode,
        id=rule.id,
        intopic=rule.intopic,
        outtopic=rule.outtopic,
        action=int(rule.action),
        mutexcmd=int(rule.mutexcmd),
    )


def script_info(info: ScriptInfo) -> types.ScriptInfo:
    """The map's ``scriptinfo`` as ``oimi_msgs/ScriptInfo``."""
    return types.ScriptInfo(
        currentactivity=info.currentactivity,
        scriptpath=info.scriptpath,
        goalid=info.goalid,
        actionid=info.actionid,
        blockid=info.blockid,
        goalname=info.goalname,
        submove=info.submove,
        subled=info.subled,
        subaout=info.subaout,
        block="" if info.block is None else msgspec.json.encode(info.block).decode(),
        script_vect=list(info.script_vect),
    )


class BridgeSession(LiveSession):
    """A live session whose body and sensors are a ROS 2 robot reached through ``node``."""

    def __init__(
        self,
        loaded: LoadedScenario,
        node: Node,
        *,
        seed: int | None = None,
        on_note: Callable[[str], None] | None = None,
    ) -> None:
        self.body = RemoteBody(loaded.scenario.robot.radius_m)
        self.remote_sensors = remote_sensors(loaded.scenario)
        super().__init__(
            loaded,
            seed=seed,
            world=self.body,
            sensors=self.remote_sensors,
            overrides=real_robot_overrides(loaded),  # camera range, ring's echoes: if left out
        )
        self.network = node.network
        self.on_note = on_note
        self.guard: JoystickGuard | None = None
        self._updates = node.reader(topics.MAP_UPDATES, depth=DEEP)
        self._joy = node.reader(topics.JOY, depth=DEEP)
        self._odometry = node.reader(topics.ODOM)
        self._cmd_vel = node.writer(topics.CMD_VEL)
        self._led = node.writer(topics.LED)
        self._audio = node.writer(topics.AUDIO)
        self._shown: tuple[tuple[float, float, float], str] | None = None
        self.sink.add(ProgressPublisher(node, self.pipeline.map))

    def attach(self, guard: JoystickGuard) -> None:
        """Hand the pad states received to the live server's joystick guard, as it takes a
        tick's input (a ``Joy`` counts in the tick that takes it, as a client's pad does)."""
        self.guard = guard

        def receive(now_s: float) -> None:
            for joy in take_all(self._joy):
                guard.receive(JOY_OWNER, pad_of(joy), now_s=now_s)  # type: ignore[arg-type]

        guard.poll(receive)

    def step(
        self,
        tick: int,
        *,
        commands: Iterable[OperatorCommand] = (),
        joystick: JoystickInput | None = None,
    ) -> None:
        """Take what arrived over DDS, run the tick, publish the body's command (the map
        updates' times on the session's clock: ``remote.RobotClock``)."""
        for update in take_all(self._updates):
            self.remote_sensors.receive(update)  # type: ignore[arg-type]
        for odometry in take_all(self._odometry):
            self.body.odometry = odometry  # type: ignore[assignment]
            self.remote_sensors.clock.odometry(odometry, now_ms=tick * self.tick_ms)  # type: ignore[arg-type]
        if self.guard is None:
            take_all(self._joy)  # no live server to drive: pad states are dropped
        for why in self.remote_sensors.refused:
            self._note(why)
        self.remote_sensors.refused.clear()
        super().step(tick, commands=commands, joystick=joystick)
        self.publish(self.outputs)

    def publish(self, outputs: ActuatorOutputs) -> None:
        """Command the body: velocity every time, LED and audio when they change."""
        twist, led, audio = outputs_message(outputs)
        self._cmd_vel.write(twist)
        shown = (outputs.led, outputs.audio)
        if shown != self._shown:
            self._shown = shown
            self._led.write(led)
            self._audio.write(audio)

    def late(self) -> None:
        """A tick is late (from the watchdog's thread: the tick holds the main one): the
        robot is told to stop moving at once, not only when cmd_vel falls silent for its
        own timeout. The next tick's command moves it again."""
        self._cmd_vel.write(outputs_message(ActuatorOutputs())[0])
        self._note("a tick is late: the robot is told to stand still until it ends")

    def stand_still(self) -> None:
        """The bridge is stopping: the robot stops, lights off, silence (waiting a moment
        for the robot to acknowledge; a robot that missed it stops when cmd_vel falls
        silent)."""
        self._shown = None
        self.publish(ActuatorOutputs())
        for writer in (self._cmd_vel, self._led, self._audio):
            # Best effort: cyclonedds 11.0.1 raises AttributeError when the wait times out.
            with contextlib.suppress(Exception):
                writer.wait_for_acks(duration(milliseconds=STOP_ACK_MS))

    def metadata(self) -> RecordingMetadata:
        return msgspec.structs.replace(
            super().metadata(),
            ros2=Ros2Record(
                role="bridge",
                domain_id=str(self.network.domain_id),
                interface=self.network.interface,
            ),
        )

    def _note(self, text: str) -> None:
        if self.on_note is not None:
            self.on_note(text)


def serve_bridge(args: argparse.Namespace) -> Served:
    """``oimi bridge``: ``oimi serve``'s live session (``live.app.serve``, the same
    arguments) whose robot is reached over DDS (the ``--dds-*`` arguments)."""
    network = network_from_args(args)

    @contextlib.contextmanager
    def bridged(loaded: LoadedScenario) -> Iterator[BridgeSession]:
        with Node(network) as node:
            session = BridgeSession(loaded, node, seed=args.seed, on_note=note)
            try:
                yield session
            finally:
                session.stand_still()

    def attach(session: LiveSession, server: LiveServer) -> None:
        assert isinstance(session, BridgeSession)
        session.attach(server.guard)

    return serve(
        args,
        command="oimi bridge",
        open_session=bridged,
        suffix="-bridge",
        on_server=attach,
        admit=admit_real,
    )


def admit_real(loaded: LoadedScenario) -> None:
    """Refuse a scenario that assumes less of the robot's people than the supervisor does
    (they are real: ``check_real_people``); say what it assumes of the lab camera's range
    and the ring's echoes that the scenario leaves out (``real_robot_warnings``)."""
    check_real_people(loaded)
    report_warnings(real_robot_warnings(loaded))
