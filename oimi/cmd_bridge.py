"""Run the pipeline as a ROS 2 participant: a live session whose robot is reached over DDS.

Subscribes to /oimi/map_updates (oimi_msgs/MapUpdate), /joy (sensor_msgs/Joy, the
Xbox 360 pad with its safety lock) and /odom; publishes /cmd_vel, /oimi/led,
/oimi/audio, the script's progress and the rules' messages and decisions. The
operator's App Interface and console work as in `oimi serve`; every input is recorded
per tick, so the recording replays with `oimi replay --mode redrive`. DDS stays on
this machine unless the --dds-* flags say otherwise (docs/ros2.md).
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Iterator

from oimi.cmd_serve import _note as note
from oimi.cmd_serve import add_arguments as add_serve_arguments
from oimi.cmd_serve import serve
from oimi.live.server import LiveServer
from oimi.live.session import LiveSession
from oimi.ros2.network import add_network_arguments, missing_extra, network_from_args
from oimi.scenarios.loader import LoadedScenario


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_serve_arguments(parser)
    add_network_arguments(parser)


def run(args: argparse.Namespace) -> int:
    if why := missing_extra():
        print(f"oimi bridge: {why}", file=sys.stderr)
        return 2
    from oimi.ros2.bridge import BridgeSession
    from oimi.ros2.dds import Node

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
        args, command="oimi bridge", open_session=bridged, suffix="-bridge", on_server=attach
    )
