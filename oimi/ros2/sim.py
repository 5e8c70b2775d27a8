"""``oimi sim --ros2``: oimi's simulated room as a ROS 2 robot.

The scenario's world (pymunk) and simulated sensors run as in ``oimi run``, paced to
the wall clock by the live server (without its operator interfaces); the robot's mind
is elsewhere. Each tick the robot takes the latest ``cmd_vel``, LED and audio commands
(a robot whose ``cmd_vel`` falls silent for ``CMD_VEL_TIMEOUT_MS`` stands still), the
world steps, and the sensors' map updates and the odometry are published.
"""

from __future__ import annotations

import argparse
import asyncio
from collections.abc import Callable, Iterable, Sequence
from typing import Final, NamedTuple

import msgspec

from oimi.cmd_check import report_warnings
from oimi.live.app import note
from oimi.live.server import Addresses, LiveServer, ServeConfig
from oimi.pipeline.errors import LocatedError
from oimi.pipeline.events import JoystickInput
from oimi.pipeline.loop import Pipeline
from oimi.pipeline.messages import ActuatorOutputs, MapUpdate
from oimi.pipeline.operator.commands import OperatorCommand
from oimi.pipeline.sink import NS_PER_MS
from oimi.recorder.metadata import RecordingMetadata, Ros2Record
from oimi.ros2 import topics, types
from oimi.ros2.dds import DEEP, Node, take_all
from oimi.ros2.network import network_from_args
from oimi.ros2.remote import odometry, outputs_of
from oimi.scenarios.loader import LoadedScenario, load_scenario
from oimi.scenarios.session.recording import recorded
from oimi.scenarios.session.runner import Session

CMD_VEL_TIMEOUT_MS: Final = 500
"""Simulated time without a ``cmd_vel`` after which the robot stands still."""


class _RemoteMind:
    """Where the session's pipeline was: publishes the sensors' updates, returns the body's
    command received over DDS. Keeps the pipeline's operator side for the session's report."""

    def __init__(self, pipeline: Pipeline, node: Node) -> None:
        self.handler = pipeline.handler
        self.actuator = pipeline.actuator
        self.outputs = ActuatorOutputs()
        self.published = 0
        """Map updates published so far."""
        self._updates = node.writer(topics.MAP_UPDATES, depth=DEEP)

    def tick(
        self,
        *,
        tick: int,
        updates: Sequence[MapUpdate] = (),
        commands: Sequence[OperatorCommand] = (),
        joystick: JoystickInput | None = None,
    ) -> ActuatorOutputs:
        for update in updates:
            self._updates.write(
                types.MapUpdate(
                    objectid=update.objectid,
                    attributename=update.attributename,
                    policy=str(update.policy),
                    jsonmsg=update.jsonmsg,
                )
            )
        self.published += len(updates)
        return self.outputs


class SimSession(Session):
    """The scenario's world and sensors, commanded over ROS 2 instead of by a pipeline."""

    def __init__(
        self,
        loaded: LoadedScenario,
        node: Node,
        *,
        seed: int | None = None,
        on_note: Callable[[str], None] | None = None,
    ) -> None:
        super().__init__(loaded, seed=seed, autostart=False)
        self.mind = _RemoteMind(self.pipeline, node)
        self.pipeline = self.mind  # type: ignore[assignment]
        self.on_note = on_note
        self._cmd_vel = node.reader(topics.CMD_VEL)
        self._led = node.reader(topics.LED)
        self._audio = node.reader(topics.AUDIO)
        self._odometry = node.writer(topics.ODOM)
        self._twist = types.Twist()
        self._colour = types.ColorRGBA()
        self._track = types.String()
        self._heard_ms: int | None = None
        self.commands_received = 0
        """``cmd_vel`` messages taken so far."""

    def metadata(self) -> RecordingMetadata:
        return msgspec.structs.replace(
            super().metadata(),
            ros2=Ros2Record(
                role="sim",
                replay="none: the world only, commanded over ROS 2; the mind ran elsewhere",
            ),
        )

    def step(
        self,
        tick: int,
        *,
        commands: Iterable[OperatorCommand] = (),
        joystick: JoystickInput | None = None,
    ) -> None:
        """Take the latest commands, step the world, publish the sensors and odometry."""
        time_ms = tick * self.tick_ms
        twists = take_all(self._cmd_vel)
        if twists:
            self._twist, self._heard_ms = twists[-1], time_ms  # type: ignore[assignment]
            self.commands_received += len(twists)
        elif self._heard_ms is not None and time_ms - self._heard_ms > CMD_VEL_TIMEOUT_MS:
            self._heard_ms = None
            self._twist = types.Twist()
            if self.on_note is not None:
                self.on_note(f"no cmd_vel for {CMD_VEL_TIMEOUT_MS} ms: standing still")
        self._colour = next(reversed(take_all(self._led)), self._colour)  # type: ignore[assignment]
        self._track = next(reversed(take_all(self._audio)), self._track)  # type: ignore[assignment]
        self.outputs = self.mind.outputs = outputs_of(self._twist, self._colour, self._track)
        super().step(tick, commands=commands, joystick=joystick)
        self._odometry.write(
            odometry(
                time_ns=time_ms * NS_PER_MS,
                pose=self.world.robot_pose(),
                velocity=self.world.robot_body_velocity(),
            )
        )


class Simulated(NamedTuple):
    """A simulation that ended: what ``oimi sim`` reports."""

    ticks: int
    published: int
    """Map updates sent."""
    received: int
    """``cmd_vel`` commands received."""
    pose: tuple[float, float, float]
    """Where the robot ended: x m, y m, heading rad."""


def simulate(args: argparse.Namespace) -> Simulated:
    """``oimi sim --ros2``: the scenario's room as a ROS 2 robot, paced to the wall clock by
    the live server (no operator interfaces) until Ctrl-C or ``--duration-s``; with
    ``--output``, its world recorded."""
    loaded = load_scenario(args.scenario)
    report_warnings(loaded.warnings)  # e.g. a sonar ring too short for the robot's speed
    network = network_from_args(args)
    if args.duration_s is not None and args.duration_s <= 0:
        raise LocatedError("--duration-s must be positive", source="oimi sim")
    config = ServeConfig(tcp_port=None, http_port=None, duration_s=args.duration_s)
    with Node(network) as node:
        session = SimSession(loaded, node, seed=args.seed, on_note=note)
        server = LiveServer(session, config, on_ready=_announce, on_note=note)
        with recorded(session, mcap=args.output, rrd=None, overwrite=args.overwrite):
            asyncio.run(server.run())
    return Simulated(
        ticks=server.ticks,
        published=session.mind.published,
        received=session.commands_received,
        pose=session.world.robot_pose(),
    )


def _announce(_: Addresses) -> None:
    print("simulating; Ctrl-C to stop", flush=True)
