"""Runs inside a private network namespace (``unshare -n``): ``oimi sim --ros2`` and
``oimi bridge`` as two processes, the operator as this one (App Interface over TCP, the
pad over ``sensor_msgs/Joy``). Writes what it saw to ``OUT/drive.json``.

Every wait is bounded (``WAIT_S``) and ends on what the robot's odometry shows; a wait
that runs out is reported, not retried.

    python tests/ros2/ros2_drive.py OUT
"""

from __future__ import annotations

import json
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

from oimi.live.inputs import NEUTRAL, Pad
from oimi.ros2 import topics, types
from oimi.ros2.dds import Node, take_all
from oimi.ros2.joy import joy_of
from oimi.ros2.network import Network

ROOM = Path(__file__).with_name("ros2_room.toml")
WAIT_S = 20.0
"""Longest wait for any one thing to happen."""
HEARTBEAT_S = 0.1
"""The pad's state is sent this often while waiting (joy_node repeats it at 20 Hz)."""
TURN = Pad(right_x=1.0, buttons=("LB",))
"""The lock held, the right stick fully right: turn clockwise, no forward speed."""


class Operator:
    """This process's DDS node: watches the odometry and cmd_vel, sends the pad's state."""

    def __init__(self, node: Node) -> None:
        self.odometry = node.reader(topics.ODOM)
        self.cmd_vel = node.reader(topics.CMD_VEL)
        self.joy = node.writer(topics.JOY)
        self.cmd = node.writer(topics.CMD_VEL)
        self.pad: Pad | None = None
        self.twist: types.Twist | None = None
        self.last: types.Odometry | None = None
        self.commands: list[types.Twist] = []

    def poll(self) -> None:
        odometry = take_all(self.odometry)
        if odometry:
            self.last = odometry[-1]  # type: ignore[assignment]
        self.commands.extend(take_all(self.cmd_vel))  # type: ignore[arg-type]
        if self.pad is not None:
            self.joy.write(joy_of(self.pad, time_ns=time.monotonic_ns()))
        if self.twist is not None:
            self.cmd.write(self.twist)

    def wait(self, what: str, done: Callable[[], bool]) -> bool:
        end = time.monotonic() + WAIT_S
        while time.monotonic() < end:
            self.poll()
            if done():
                return True
            time.sleep(HEARTBEAT_S)
        print(f"gave up waiting for: {what}", file=sys.stderr)
        return False

    def velocity(self) -> tuple[float, float]:
        """The robot's forward speed and turn rate, as its odometry reports them."""
        if self.last is None:
            return (0.0, 0.0)
        twist = self.last.twist.twist
        return (twist.linear.x, twist.angular.z)


def oimi(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "oimi", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def end(process: subprocess.Popen[str]) -> tuple[int, str, str]:
    """Ctrl-C, then its exit code and what it printed."""
    process.send_signal(signal.SIGINT)
    try:
        stdout, stderr = process.communicate(timeout=WAIT_S)
    except subprocess.TimeoutExpired:
        process.kill()
        stdout, stderr = process.communicate()
    return process.returncode, stdout, stderr


def request(stream: socket.socket, reader, **fields: object) -> dict:  # type: ignore[no-untyped-def]
    stream.sendall(json.dumps(fields).encode() + b"\n")
    while True:
        message = json.loads(reader.readline())
        if message.get("type") == "reply":
            return message


def main(out: Path) -> int:
    result: dict[str, object] = {}
    sim = oimi("sim", "--ros2", str(ROOM), "-o", str(out / "sim.mcap"), "--duration-s", "60")
    bridge = oimi(
        "bridge", str(ROOM), "-o", str(out / "bridge.mcap"), "--port", "0", "--no-console",
        "--duration-s", "60",
    )  # fmt: skip
    try:
        assert bridge.stdout is not None
        port = None
        for line in bridge.stdout:
            if found := re.match(r"app interface: tcp [\d.]+:(\d+)", line):
                port = int(found[1])
                break
        assert port is not None, "the bridge did not start"
        with Node(Network()) as node:
            op = Operator(node)
            result["connected"] = op.wait(
                "odometry from the sim and cmd_vel from the bridge",
                lambda: op.last is not None and len(op.commands) > 0,
            )
            with socket.create_connection(("127.0.0.1", port), timeout=WAIT_S) as stream:
                reader = stream.makefile("r")
                result["get_ready"] = request(stream, reader, cmd="get_ready")["ok"]
                result["start"] = request(stream, reader, cmd="start")["ok"]
            result["script_drives"] = op.wait(
                "the activity to drive the robot forward", lambda: op.velocity()[0] > 0.08
            )
            op.pad = TURN
            result["joystick_turns"] = op.wait(
                "the pad to turn the robot clockwise",
                lambda: op.velocity()[1] < -0.5 and abs(op.velocity()[0]) < 0.02,
            )
            op.pad = NEUTRAL
            result["stops_on_release"] = op.wait(
                "the robot to stop after the lock's release",
                lambda: max(map(abs, op.velocity())) < 1e-3,
            )
            op.commands.clear()
            op.wait("twenty more commands", lambda: len(op.commands) >= 20)
            result["still_after_release"] = [
                (c.linear.x, c.linear.y, c.angular.z) for c in op.commands[:20]
            ]
            op.pad = None
            # The bridge goes; someone else drives the robot, then falls silent.
            result["bridge_exit"], result["bridge_stdout"], result["bridge_stderr"] = end(bridge)
            op.twist = types.Twist(linear=types.Vector3(x=0.2))
            result["moves_again"] = op.wait(
                "cmd_vel from this process to move the robot", lambda: op.velocity()[0] > 0.05
            )
            op.twist = None
            result["silence_stops"] = op.wait(
                "the robot to stop when cmd_vel falls silent",
                lambda: max(map(abs, op.velocity())) < 1e-3,
            )
    finally:
        for name, process in (("bridge", bridge), ("sim", sim)):
            if process.returncode is None:
                result[f"{name}_exit"], result[f"{name}_stdout"], result[f"{name}_stderr"] = end(
                    process
                )
    (out / "drive.json").write_text(json.dumps(result, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(sys.argv[1])))
