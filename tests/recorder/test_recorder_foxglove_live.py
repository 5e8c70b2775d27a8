"""Foxglove live: a Foxglove WebSocket client (a plain `websockets` client speaking the
protocol's subprotocol) sees the MCAP's channels and schemas, and receives messages, from
the live sink, from `oimi serve --foxglove` and from `oimi replay --foxglove`."""

from __future__ import annotations

import asyncio
import json
import re
import socket
import struct
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import msgspec
import pytest
import websockets
from oimi.pipeline.events import Topic
from oimi.recorder.errors import RecordingError
from oimi.recorder.foxglove_live import FoxgloveLiveSink, FoxgloveServer, loopback_host
from oimi.recorder.reader import open_recording
from oimi.recorder.topics import FoxgloveTopic, foxglove_schema, schema_data, schema_name
from recorder_synthetic import SCENE, TICK_NS, session, world_state

from oimi.cli import main

ROOT = Path(__file__).resolve().parents[2]
SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]
TIMEOUT_S = 10


class Client:
    """A Foxglove WebSocket client: the advertised channels, subscriptions, messages."""

    def __init__(self, ws: websockets.ClientConnection) -> None:
        self.ws = ws
        self.channels: dict[int, dict] = {}
        self.subscriptions: dict[int, str] = {}

    async def until_advertised(self, count: int) -> None:
        while len(self.channels) < count:
            frame = json.loads(await asyncio.wait_for(self.ws.recv(), TIMEOUT_S))
            if frame["op"] == "advertise":
                self.channels.update({c["id"]: c for c in frame["channels"]})

    async def subscribe(self, topics: list[str]) -> None:
        wanted = [c for c in self.channels.values() if c["topic"] in topics]
        subs = [{"id": i, "channelId": c["id"]} for i, c in enumerate(wanted, start=1)]
        self.subscriptions = {i: c["topic"] for i, c in enumerate(wanted, start=1)}
        await self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    async def message(self) -> tuple[str, int, bytes]:
        """The next message: topic, log time (ns), payload."""
        while True:
            frame = await asyncio.wait_for(self.ws.recv(), TIMEOUT_S)
            if isinstance(frame, bytes) and frame[0] == 1:
                sub, time_ns = struct.unpack_from("<IQ", frame, 1)
                return self.subscriptions[sub], time_ns, frame[13:]


def connect(port: int, **options: object) -> websockets.connect:
    return websockets.connect(f"ws://127.0.0.1:{port}", subprotocols=SUBPROTOCOLS, **options)


MCAP_TOPICS = [*(t.value for t in Topic), *(f.value for f in FoxgloveTopic)]


def test_the_live_sink_advertises_the_mcaps_channels_and_streams_its_messages() -> None:
    sink = FoxgloveLiveSink(port=0, scene=SCENE, every_n_ticks=1)
    events = session(4)

    async def main() -> list[tuple[str, int, bytes]]:
        async with connect(sink.server.port) as ws:
            assert ws.subprotocol in SUBPROTOCOLS
            client = Client(ws)
            await client.until_advertised(len(MCAP_TOPICS))
            by_topic = {c["topic"]: c for c in client.channels.values()}
            assert sorted(by_topic) == sorted(MCAP_TOPICS)
            for topic in Topic:
                channel = by_topic[topic.value]
                assert channel["schemaName"] == schema_name(topic)
                assert channel["schema"].encode() == schema_data(topic)
                assert (channel["encoding"], channel["schemaEncoding"]) == ("json", "jsonschema")
            title, data = foxglove_schema(FoxgloveTopic.SCENE)
            assert by_topic["/foxglove/scene"]["schemaName"] == title == "foxglove.SceneUpdate"
            assert by_topic["/foxglove/scene"]["schema"].encode() == data
            topics = ["/world/state", "/foxglove/scene", "/foxglove/arena"]
            await client.subscribe(topics)
            for _ in range(100):  # the server takes the subscription in its own time
                if all(sink.subscribed(t) for t in topics):
                    break
                await asyncio.sleep(0.05)
            for topic, time_ns, message in events:
                sink.record(topic, time_ns, message)
            return [await client.message() for _ in range(8)]

    try:
        received = asyncio.run(main())
    finally:
        sink.close()
    states = [(t, m) for topic, t, m in received if topic == "/world/state"]
    sent = [(t, msgspec.json.encode(m)) for topic, t, m in events if topic == Topic.WORLD_STATE]
    assert states == sent[: len(states)] and len(states) >= 3, "the MCAP's bytes, in order"

    def drawn(topic: str) -> list[str]:
        scenes = [json.loads(m) for t, _, m in received if t == topic]
        return [e["id"] for scene in scenes for e in scene["entities"]]

    assert "robot" in drawn("/foxglove/scene") and "arena" in drawn("/foxglove/arena")


def test_a_client_that_joins_late_gets_the_arena_and_the_bodies_once_a_second() -> None:
    """The scene is sent when its look changes; a live server sends it again, with the
    arena, once a simulated second, or a client that joined since would draw no body."""
    sink = FoxgloveLiveSink(port=0, scene=SCENE, every_n_ticks=5)
    sent: list[tuple[str, int]] = []
    sink._log = lambda topic, time_ns, message: sent.append((topic, time_ns))  # type: ignore[method-assign]
    try:
        for tick in range(0, 120, 2):  # the same look every fifth tick (LEDs off, a sound)
            sink.record(Topic.WORLD_STATE, tick * TICK_NS, world_state(tick))
    finally:
        sink.close()

    def times(topic: str) -> list[int]:
        return [t // TICK_NS for name, t in sent if name == topic]

    assert times("/foxglove/scene") == [0, 10, 50, 100]  # new look at 0 and 10, then resent
    assert times("/foxglove/arena") == [0, 50, 100]
    assert times("/foxglove/tf") == list(range(0, 120, 10))


def test_the_server_refuses_a_non_loopback_address() -> None:
    assert loopback_host("127.0.0.1") == "127.0.0.1"
    with pytest.raises(RecordingError, match="loopback only"):
        loopback_host("0.0.0.0")


def first_line_matching(process: subprocess.Popen[str], pattern: str) -> re.Match[str]:
    for _ in range(50):
        line = process.stdout.readline()
        if not line:
            break
        if found := re.search(pattern, line):
            return found
    process.kill()
    raise AssertionError(f"no line matching {pattern!r}: {process.communicate()}")


def oimi_process(*args: str | Path) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "oimi", *map(str, args)],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


async def receive_world_states(port: int, count: int) -> list[int]:
    async with connect(port) as ws:
        client = Client(ws)
        await client.until_advertised(len(MCAP_TOPICS))
        await client.subscribe(["/world/state"])
        received = [await client.message() for _ in range(count)]
    return [msgspec.json.decode(m)["tick"] for _, _, m in received]


def test_oimi_serve_foxglove_serves_the_live_session(tmp_path: Path) -> None:
    scenario = ROOT / "scenarios" / "library" / "greeting.toml"
    process = oimi_process(
        "serve", scenario, "--no-tcp", "--no-console", "--foxglove", "0",
        "--duration-s", "4", "-o", tmp_path / "live.mcap",
    )  # fmt: skip
    try:
        port = int(first_line_matching(process, r"foxglove: ws://127\.0\.0\.1:(\d+)")[1])
        ticks = asyncio.run(receive_world_states(port, 3))
    finally:
        _, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    assert ticks == sorted(ticks) and len(set(ticks)) == 3


def recorded_blink(folder: Path) -> Path:
    """The library's blink scenario run by ``oimi run`` (20 s, 1,542 messages)."""
    path = folder / "blink.mcap"
    blink = ROOT / "scenarios" / "library" / "blink.toml"
    run = subprocess.run(
        [sys.executable, "-m", "oimi", "run", blink, "-q", "-o", path],
        cwd=ROOT,
        capture_output=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    return path


def test_oimi_replay_foxglove_streams_the_recording_to_a_client(tmp_path: Path) -> None:
    process = oimi_process("replay", recorded_blink(tmp_path), "--foxglove", "0", "--speed", "0")
    started = time.monotonic()
    try:
        port = int(first_line_matching(process, r"foxglove: ws://127\.0\.0\.1:(\d+)")[1])
        ticks = asyncio.run(receive_world_states(port, 6))
    finally:
        out, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    assert ticks == [0, 2, 4, 6, 8, 10]  # as recorded: every second tick
    assert re.search(r"foxglove: \d+ messages streamed", out)
    assert time.monotonic() - started < 60


def test_oimi_replay_foxglove_refuses_a_port_in_use_before_replaying(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    recording = recorded_blink(tmp_path)
    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
        assert main(["replay", str(recording), "--foxglove", str(port), "-q"]) == 2
    out, err = capsys.readouterr()
    assert f"cannot start the Foxglove server on 127.0.0.1:{port}" in err
    assert "replay of" not in out  # (it had redriven the whole recording first)


async def receive_everything(
    port: int, expected: int, *, stalled: Callable[[], object] = lambda: None
) -> int:
    """Subscribe to every channel, call ``stalled()`` before reading anything (a client that
    falls behind), then count the messages until ``expected`` or the server closes."""
    received = 0
    with socket.socket() as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # little held for us
        sock.connect(("127.0.0.1", port))
        async with connect(port, sock=sock) as ws:
            client = Client(ws)
            await client.until_advertised(len(MCAP_TOPICS))
            await client.subscribe(MCAP_TOPICS)
            stalled()
            try:
                while received < expected:
                    await client.message()
                    received += 1
            except (websockets.ConnectionClosed, TimeoutError):
                pass
    return received


def test_oimi_replay_foxglove_at_once_drops_nothing_past_the_sdks_backlog(tmp_path: Path) -> None:
    recording = recorded_blink(tmp_path)
    process = oimi_process("replay", recording, "--foxglove", "0", "--speed", "0")
    try:
        port = int(first_line_matching(process, r"foxglove: ws://127\.0\.0\.1:(\d+)")[1])
        received = asyncio.run(receive_everything(port, message_count(recording)))
    finally:
        out, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    sent = int(re.search(r"foxglove: (\d+) messages streamed", out)[1])  # type: ignore[index]
    assert sent > 1024, "more than the SDK's default backlog"
    assert received == sent


def message_count(recording: Path) -> int:
    return sum(open_recording(recording).summary.values())


def test_oimi_replay_foxglove_serves_a_slow_client_until_it_has_everything(
    tmp_path: Path,
) -> None:
    """A client that reads nothing for a while after the server streamed a large file
    (more than the sockets hold) still receives all of it: the server waits for it to
    leave (it stopped 1 s after the last message)."""
    recording = tmp_path / "busy.mcap"
    busy = ROOT / "scenarios" / "library" / "busy_playroom.toml"
    argv = ["run", busy, "-q", "-o", recording, "--world-every", "1", "--param", "duration_s=120"]
    run = subprocess.run([sys.executable, "-m", "oimi", *argv], cwd=ROOT, capture_output=True)
    assert run.returncode == 0, run.stderr
    process = oimi_process("replay", recording, "--foxglove", "0", "--speed", "0")
    said: list[str] = []

    def stalled() -> None:  # blocks the client's loop: it reads nothing meanwhile
        said.append(first_line_matching(process, r"foxglove: \d+ messages streamed.*")[0])
        time.sleep(1.5)

    try:
        port = int(first_line_matching(process, r"foxglove: ws://127\.0\.0\.1:(\d+)")[1])
        expected = message_count(recording)
        received = asyncio.run(receive_everything(port, expected, stalled=stalled))
    finally:
        out, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    assert received == expected > 10_000
    assert said == [
        f"foxglove: {expected} messages streamed; serving until the client disconnects"
        " (Ctrl-C to stop; at most 10 min)"
    ]
    assert "time limit" not in out


def test_the_server_serves_a_subscribed_client_until_it_leaves_or_the_limit() -> None:
    server = FoxgloveServer(port=0)
    channel = server.channel("/x", "x", b"{}", "json")

    async def subscribed_then_gone() -> tuple[bool, float, bool, float]:
        async with connect(server.port) as ws:
            client = Client(ws)
            await client.until_advertised(1)
            await client.subscribe(["/x"])
            for _ in range(200):
                if channel.has_sinks():
                    break
                await asyncio.sleep(0.01)
            started = time.monotonic()
            held = await asyncio.to_thread(server.wait_while_subscribed, limit_s=0.3)
            waited = time.monotonic() - started
        started = time.monotonic()
        left = await asyncio.to_thread(server.wait_while_subscribed, limit_s=10)
        return held, waited, left, time.monotonic() - started

    try:
        held, waited, left, then = asyncio.run(subscribed_then_gone())
    finally:
        server.close()
    assert not held and 0.3 <= waited < 5, "a client that stays: the limit"
    assert left and then < 5, "a client that left: at once"
