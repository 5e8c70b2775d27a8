"""``oimi serve`` over TCP: the operator's commands of thesis 5.1 from a socket client, the
interface's robustness, the dead-man, and a recording that replays exactly."""

from __future__ import annotations

import socket
import time

import pytest
from live_helpers import LineClient, served, states
from oimi.pipeline.events import JoystickInput, Topic, WorldState
from oimi.recorder.reader import open_recording
from oimi.replay.redrive import redrive

from oimi.live.protocol import MAX_LINE_BYTES


def test_tcp_client_runs_a_session_and_the_recording_replays_clean(tmp_path):
    recording = tmp_path / "live.mcap"
    with served(recording) as live:
        client = LineClient.connect(live.tcp_port)
        assert client.read()["type"] == "hello"
        listed = client.call(cmd="list")
        assert listed["ok"]
        dance = next(g for g in listed["catalogue"] if g["name"] == "test_dance")
        assert {o["name"] for o in dance["options"]} >= {"tempo", "colours"}
        assert client.call(cmd="subscribe")["ok"]

        assert client.call(cmd="add", activity="example_act")["ok"]
        added = client.call(cmd="add", activity="test_dance", options={"tempo": "slow"})
        assert added["ok"] and added["tick"] >= 0
        duplicate = client.call(cmd="add", activity="test_dance")
        assert not duplicate["ok"] and "already" in duplicate["reason"]
        assert client.call(cmd="get_ready")["ok"]
        client.state_where(lambda s: s["button"] == "start")
        assert client.call(cmd="start")["ok"]
        running = client.state_where(lambda s: states(s).get("example_act") == "completed")
        assert running["button"] == "stop"
        assert states(running)["test_dance"] == "current"
        assert running["block"]["activity"] == "test_dance"
        refused = client.call(cmd="reorder", activity="test_dance", position=0)
        assert not refused["ok"] and "stop first" in refused["reason"]

        assert client.call(cmd="stop")["ok"]
        stopped = client.state_where(lambda s: s["button"] == "start")
        assert states(stopped) == {"example_act": "completed", "test_dance": "not_yet_completed"}
        assert client.call(cmd="reorder", activity="test_dance", position=0)["ok"]
        assert client.call(cmd="restart")["ok"]
        restarted = client.state_where(
            lambda s: (
                [a["name"] for a in s["activities"]] == ["test_dance", "example_act"]
                and set(states(s).values()) == {"not_yet_completed"}
            )
        )
        assert restarted["button"] == "start"
        assert client.call(cmd="clear")["ok"]
        assert client.state_where(lambda s: s["activities"] == [])["button"] == "get_ready"
        client.close()
        live.stop()
    assert live.returncode == 0, live.errors
    assert "recording:" in live.output

    rec = open_recording(recording)
    recorded = [
        c
        for m in rec.iter_messages(topics=[Topic.OPERATOR_COMMANDS])
        for c in m.decoded().commands  # type: ignore[attr-defined]
    ]
    assert [c.id for c in recorded] == list(range(1, len(recorded) + 1))  # the session's
    commands = [c.verb for c in recorded]
    assert commands[:4] == ["list", "add", "add", "add"]
    assert commands[-4:] == ["stop", "reorder", "restart", "clear"]
    comparison = redrive(recording)
    assert comparison.ok, comparison.divergence
    assert comparison.compared[Topic.OPERATOR_COMMANDS] >= 10


def test_bad_lines_are_refused_and_the_session_goes_on(tmp_path):
    with served(tmp_path / "bad.mcap") as live:
        client = LineClient.connect(live.tcp_port)
        client.read()
        client.send_raw(b"{not json\n")
        assert client.read() == {
            "type": "reply",
            "id": None,
            "ok": False,
            "reason": client.seen[-1]["reason"],
        }
        assert client.seen[-1]["reason"].startswith("malformed JSON")
        unknown = client.call(cmd="dance_wildly")
        assert not unknown["ok"] and "$.cmd" in unknown["reason"]
        extra = client.call(cmd="add", activity="test_dance", colour="red")
        assert not extra["ok"] and "unknown field `colour`" in extra["reason"]
        typed = client.call(cmd="reorder", activity="x", position="first")
        assert not typed["ok"] and "$.position" in typed["reason"]
        bad_option = client.call(cmd="add", activity="test_dance", options={"tempo": "lively"})
        assert not bad_option["ok"] and "tempo" in bad_option["reason"]

        # A vanished client (mid-line) and an oversized message do not disturb the others.
        other = LineClient.connect(live.tcp_port)
        other.read()
        other.send_raw(b'{"id": 1, "cmd": "li')
        other.sock.close()
        big = LineClient.connect(live.tcp_port)
        big.read()
        big.send_raw(b"x" * (MAX_LINE_BYTES + 10) + b"\n")
        too_long = big.read()
        assert not too_long["ok"] and "too long" in too_long["reason"]
        with pytest.raises((ConnectionError, socket.timeout, OSError)):
            big.read(timeout_s=2)
        assert client.call(cmd="add", activity="example_act")["ok"]
        state = client.call(cmd="state")["state"]
        assert states(state) == {"example_act": "not_yet_completed"}

        # Two clients' commands with the same id: each reply echoes its client's id.
        same = LineClient.connect(live.tcp_port)
        same.read()
        client.send(id=99, cmd="add", activity="test_dance")
        same.send(id=99, cmd="remove", activity="nothing")
        assert client.reply_to(99)["ok"]
        refused = same.reply_to(99)
        assert not refused["ok"] and refused["reason"] == "'nothing' is not selected"
        client.close()
        same.close()
        big.close()
        live.stop()
    assert live.returncode == 0, live.errors


def test_a_client_that_stops_reading_is_dropped(tmp_path):
    with served(tmp_path / "slow.mcap") as live:
        slow = socket.create_connection(("127.0.0.1", live.tcp_port))
        slow.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        request = b'{"cmd": "list"}\n' * 4000
        slow.sendall(request)  # thousands of catalogue replies it never reads
        client = LineClient.connect(live.tcp_port)
        client.read()
        started = time.monotonic()
        assert client.call(cmd="add", activity="example_act")["ok"]
        assert time.monotonic() - started < 2.0
        client.close()
        slow.close()
        live.stop()
    assert live.returncode == 0, live.errors


def test_token_guards_the_port(tmp_path):
    with served(tmp_path / "token.mcap", "--token", "s3cret") as live:
        client = LineClient.connect(live.tcp_port)
        assert client.read()["auth_required"] is True
        refused = client.call(cmd="add", activity="example_act")
        assert not refused["ok"] and refused["reason"].startswith("unauthorised")
        assert not client.call(cmd="auth", token="guess")["ok"]
        assert client.call(cmd="auth", token="s3cret")["ok"]
        assert client.call(cmd="add", activity="example_act")["ok"]
        client.close()
        live.stop()


def test_silent_joystick_releases_the_lock_and_the_robot_stops(tmp_path):
    recording = tmp_path / "deadman.mcap"
    with served(recording) as live:
        client = LineClient.connect(live.tcp_port)
        client.read()
        assert client.call(cmd="joystick", left_y=1.0, buttons=["LB"])["ok"]
        time.sleep(1.5)  # no heartbeat: released after 0.5 s
        fast = LineClient.connect(live.tcp_port)
        fast.read()
        assert fast.call(cmd="joystick", left_y=1.0, buttons=["LB"])["ok"]
        time.sleep(0.1)
        fast.close()  # a vanished pad releases the lock at once, before the heartbeat's 0.5 s
        time.sleep(0.6)
        client.close()
        live.stop()
    rec = open_recording(recording)
    pads = [m.decoded() for m in rec.iter_messages(topics=[Topic.JOYSTICK])]
    assert [p.buttons for p in pads if isinstance(p, JoystickInput)] == [("LB",), (), ("LB",), ()]
    engaged, released = pads[0].tick, pads[1].tick
    assert 0.5 <= (released - engaged) * 20 / 1000 < 1.0
    assert pads[3].tick - pads[2].tick < 0.4 * 50
    last = None
    for m in rec.iter_messages(topics=[Topic.WORLD_STATE]):
        last = m.decoded()
    assert isinstance(last, WorldState)
    assert abs(last.robot.vx_mps) < 1e-6 and abs(last.robot.vy_mps) < 1e-6
    assert redrive(recording).ok
