"""The live server under attack (issue 14), each against a real ``oimi serve`` on loopback:
a joystick backlog cannot outrun the dead-man, foreign web pages and HTTP bodies drive
nothing, a flood of idle connections does not lock the operator out, tokens cannot be
guessed quickly, and the attacked session's recording re-drives identically."""

from __future__ import annotations

import itertools
import json
import math
import resource
import socket
import subprocess
import sys
import time

import pytest
from live_helpers import ROOT, LineClient, http_status, port_of, served, states, upgrade
from oimi.pipeline.events import (
    ActuatorCommands,
    JoystickInput,
    LockRelease,
    Source,
    Topic,
    WorldState,
)
from oimi.recorder.reader import open_recording

BURST = 200
"""Joystick states sent at once, toggling a button: 4 s of motion if they queued (one per
tick); under the 256 replies a client may leave unread before it is dropped."""


def burst(client: LineClient, count: int) -> None:
    """``count`` locked full-stick states as fast as the socket takes them, X toggling."""
    lines = []
    for i in range(count):
        buttons = ["LB", "X"] if i % 2 else ["LB"]
        body = {"id": client.next_id, "cmd": "joystick", "left_y": 1.0, "buttons": buttons}
        client.next_id += 1
        lines.append(json.dumps(body).encode() + b"\n")
    client.send_raw(b"".join(lines))


def recorded_inputs(path):
    rec = open_recording(path)
    pads = [m.decoded() for m in rec.iter_messages(topics=[Topic.JOYSTICK])]
    commands = [m.decoded() for m in rec.iter_messages(topics=[Topic.ACTUATOR_COMMANDS])]
    world = [m.decoded() for m in rec.iter_messages(topics=[Topic.WORLD_STATE])]
    assert all(isinstance(p, JoystickInput) for p in pads)
    assert all(isinstance(c, ActuatorCommands) for c in commands)
    assert all(isinstance(w, WorldState) for w in world)
    return pads, commands, world


def assert_stopped_at(release_tick: int, until: int, pads, commands, world) -> None:
    """From ``release_tick`` (+1) to ``until``: no locked input, no joystick motion
    command, and the robot only brakes (its speed never grows) until it stands."""
    assert not [p.tick for p in pads if release_tick < p.tick < until and "LB" in p.buttons]
    driving = [
        m.tick
        for m in commands
        if release_tick < m.tick < until
        for command in m.commands
        if command.source is Source.JOYSTICK
    ]
    assert not driving
    speeds = [
        (w.tick, math.hypot(w.robot.vx_mps, w.robot.vy_mps))
        for w in world
        if release_tick + 1 <= w.tick < until
    ]
    assert all(b <= a + 1e-9 for (_, a), (_, b) in itertools.pairwise(speeds))
    assert speeds[-1][1] < 1e-6, "standing by the end"


def test_a_joystick_backlog_stops_within_a_tick_and_the_session_redrives(tmp_path):
    recording = tmp_path / "backlog.mcap"
    with served(recording) as live:
        # 1. hundreds of states in one go, then the lock let go: the last byte wins
        attacker = LineClient.connect(live.tcp_port)
        attacker.read()
        assert attacker.call(cmd="joystick", left_y=1.0, buttons=["LB"])["ok"]
        time.sleep(0.3)  # driving (within the heartbeat's 0.5 s)
        burst(attacker, BURST)
        let_go = attacker.send(cmd="joystick", buttons=[])
        last_tick = attacker.reply_to(let_go, timeout_s=20)["tick"]
        attacker.close()
        # 2. the same burst, then the client vanishes while holding the lock
        time.sleep(0.8)
        vanishing = LineClient.connect(live.tcp_port)
        vanishing.read()
        burst(vanishing, BURST)
        held = vanishing.send(cmd="joystick", left_y=1.0, buttons=["LB"])
        held_tick = vanishing.reply_to(held, timeout_s=20)["tick"]
        vanishing.close()
        time.sleep(0.8)
        live.stop()
    assert live.returncode == 0, live.errors
    assert "Traceback" not in live.errors

    pads, commands, world = recorded_inputs(recording)
    released = [p for p in pads if p.release is not None]
    assert [p.release for p in released] == [LockRelease.OPERATOR, LockRelease.DISCONNECTED]
    first, second = released
    assert first.tick == last_tick, "released in the tick the last byte was applied"
    assert first.buttons == () and first.left_y == 0.0
    stop = next(m for m in commands if m.tick == first.tick)
    assert [(c.source, c.stop) for c in stop.commands] == [(Source.SAFETY, True)]
    engaged = [p.tick for p in pads if p.tick <= first.tick and "LB" in p.buttons]
    assert len(engaged) <= first.tick - engaged[0] + 1, "at most one input per tick: no queue"
    again = next(p.tick for p in pads if p.tick > first.tick and "LB" in p.buttons)
    assert_stopped_at(first.tick, again, pads, commands, world)

    assert second.tick >= held_tick
    assert_stopped_at(second.tick, world[-1].tick + 1, pads, commands, world)
    assert "safety lock released (disconnected)" in live.errors or "disconnected" in live.errors

    done = subprocess.run(
        [sys.executable, "-m", "oimi", "replay", str(recording), "--mode", "redrive"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stdout + done.stderr


def test_foreign_origins_and_http_bodies_are_refused_and_change_nothing(tmp_path):
    recording = tmp_path / "foreign.mcap"
    proxy = "https://tablet.example:8443"
    with served(recording, "--allow-origin", proxy) as live:
        port = port_of(live.console)
        own = f"http://127.0.0.1:{port}"
        refused = {
            "evil": upgrade(port, origin="http://evil.example"),
            "null": upgrade(port, origin="null"),
            "none": upgrade(port),
            "rebinding": upgrade(
                port, host=f"evil.example:{port}", origin=f"http://evil.example:{port}"
            ),
            "other port": upgrade(port, origin="http://127.0.0.1:1"),
        }
        for name, request in refused.items():
            assert http_status(port, request).startswith("HTTP/1.1 403"), name
        page = f"GET / HTTP/1.1\r\nHost: evil.example:{port}\r\n\r\n".encode()
        assert http_status(port, page).startswith("HTTP/1.1 403")
        assert http_status(port, upgrade(port, origin=own)).startswith("HTTP/1.1 101")
        behind_proxy = upgrade(port, host="tablet.example:8443", origin=proxy)
        assert http_status(port, behind_proxy).startswith("HTTP/1.1 101")  # --allow-origin

        # what a browser's fetch(..., {mode: "no-cors", method: "POST"}) sends to port 7070
        body = (
            b'{"id": 1, "cmd": "add", "activity": "example_act"}\n'
            b'{"id": 2, "cmd": "joystick", "left_y": 1.0, "buttons": ["LB"]}\n'
        )
        post = (
            b"POST / HTTP/1.1\r\nHost: 127.0.0.1:%d\r\nContent-Type: text/plain\r\n"
            b"Content-Length: %d\r\n\r\n" % (live.tcp_port, len(body))
        ) + body
        wrapped = LineClient.connect(live.tcp_port)
        wrapped.read()  # the hello, sent on connection
        wrapped.send_raw(post)
        with pytest.raises((ConnectionError, OSError)):
            for _ in range(5):
                wrapped.read(timeout_s=3)  # closed with no reply to any line
        wrapped.close()

        operator = LineClient.connect(live.tcp_port)
        operator.read()
        assert states(operator.call(cmd="state")["state"]) == {}
        operator.close()
        live.stop()
    assert live.returncode == 0, live.errors
    rec = open_recording(recording)
    assert rec.summary.get(Topic.OPERATOR_COMMANDS, 0) == 0
    assert rec.summary.get(Topic.JOYSTICK, 0) == 0


@pytest.fixture(scope="module")
def guarded(tmp_path_factory):
    """One server with a token and only 256 open files, for the flood and the guesser."""
    recording = tmp_path_factory.mktemp("guarded") / "guarded.mcap"
    with served(recording, "--token", "s3cret", max_files=256) as live:
        yield live
        live.stop()
    assert live.returncode == 0, live.errors
    assert "Traceback" not in live.errors and "Traceback" not in live.output


def once_through(attempt, tries: int = 10):
    """``attempt()``, made again (a bounded number of times) while the server is still
    accepting the flood queued before it: each connection it accepts evicts the oldest
    pending one, which may be the attempt's (closed or reset by the server)."""
    for _ in range(tries - 1):
        try:
            answer = attempt()
        except ConnectionError:
            answer = None
        if answer:
            return answer
        time.sleep(0.2)
    return attempt()


def hello_from(port: int) -> dict:
    probe = LineClient.connect(port)
    try:
        return probe.read()
    finally:
        probe.close()


def test_a_thousand_idle_connections_neither_lock_out_the_operator_nor_trace(guarded):
    live = guarded
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard != resource.RLIM_INFINITY and hard < 1200:
        pytest.skip(f"the file limit {hard} is too low for 1,000 client sockets")
    resource.setrlimit(resource.RLIMIT_NOFILE, (max(soft, 1200), hard))
    idle: list[socket.socket] = []
    try:
        ports = (live.tcp_port, port_of(live.console))
        for i in range(1000):  # far over the server's 256 files
            idle.append(socket.create_connection(("127.0.0.1", ports[i % 2]), timeout=5))
        # both accept queues worked through: a later connection on each port is answered
        page = f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{ports[1]}\r\n\r\n".encode()
        assert once_through(lambda: http_status(ports[1], page)) == "HTTP/1.1 200 OK"
        assert once_through(lambda: hello_from(live.tcp_port))["type"] == "hello"
        operator = LineClient.connect(live.tcp_port)
        hello = operator.read()
        assert hello == {"type": "hello", "auth_required": True}
        before = operator.call(cmd="state")
        assert not before["ok"] and "state" not in before, "nothing before authentication"
        assert operator.call(cmd="auth", token="s3cret")["ok"]
        assert operator.read()["scenario"] == "live_room"  # the full hello, now
        assert operator.call(cmd="add", activity="example_act")["ok"]
        status = http_status(ports[1], upgrade(ports[1], origin=f"http://127.0.0.1:{ports[1]}"))
        assert status.startswith("HTTP/1.1 101")
        operator.close()
    finally:
        for sock in idle:
            sock.close()
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
    assert live.process.poll() is None, "still serving"


def test_token_guessing_is_slowed_and_cut_off(guarded):
    live = guarded
    guesser = LineClient.connect(live.tcp_port)
    assert guesser.read() == {"type": "hello", "auth_required": True}
    started = time.monotonic()
    guesser.send_raw(
        b"".join(b'{"id": %d, "cmd": "auth", "token": "guess%d"}\n' % (i, i) for i in range(50))
    )
    answers = []
    with pytest.raises((ConnectionError, OSError)):
        for _ in range(50):
            answers.append(guesser.read(timeout_s=5))
    elapsed = time.monotonic() - started
    assert [a["reason"] for a in answers] == [
        "wrong token (1 of 3); the next answer comes after 0.25 s",
        "wrong token (2 of 3); the next answer comes after 0.5 s",
        "wrong token: closing",
    ]
    assert elapsed >= 0.25 + 0.5, "each answer after a failure waits"
    guesser.close()

    # the next connection from the same address waits longer, even with the right token
    operator = LineClient.connect(live.tcp_port)
    operator.read()
    started = time.monotonic()
    assert operator.call(cmd="auth", token="s3cret")["ok"]
    assert time.monotonic() - started >= 1.0
    assert "activities" in operator.call(cmd="state")["state"]  # admitted
    operator.close()


def test_an_open_address_without_a_token_is_refused(tmp_path):
    done = subprocess.run(
        [
            *(sys.executable, "-m", "oimi", "serve", ROOT / "tests/live/live_room.toml"),
            *("--host", "0.0.0.0", "-o", tmp_path / "open.mcap"),
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert "--host: listening on 0.0.0.0 needs --token" in done.stderr
    assert "Traceback" not in done.stderr
    assert list(tmp_path.iterdir()) == []
