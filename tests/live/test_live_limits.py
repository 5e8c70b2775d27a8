"""The live server's limits, in-process with small values: a pending connection times out,
a silent admitted one is closed, the admitted are capped, a request flood is cut off."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Awaitable, Callable

import pytest
from live_helpers import ROOM
from oimi.scenarios.loader import load_scenario

from oimi.live import connections, server
from oimi.live.server import LiveServer, ServeConfig, listen
from oimi.live.session import LiveSession

WAIT_S = 10.0
"""Generous: each limit here acts within a second or two."""


def serve_with(
    monkeypatch: pytest.MonkeyPatch,
    client: Callable[[int], Awaitable[list[dict]]],
    *,
    token: str | None = None,
    **limits: float,
) -> list[dict]:
    """Run a live server on a free port with ``limits`` patched while ``client(port)`` runs;
    what the client returns."""
    for name, value in limits.items():  # where the limit is read
        monkeypatch.setattr(server if hasattr(server, name) else connections, name, value)
    config = ServeConfig(tcp_port=0, http_port=None, token=token)
    live = LiveServer(LiveSession(load_scenario(ROOM)), config)

    async def main() -> list[dict]:
        listeners = listen(config)
        running = asyncio.create_task(live.run(listeners))
        try:
            return await asyncio.wait_for(client(listeners.tcp.getsockname()[1]), WAIT_S)
        finally:
            await asyncio.sleep(0.05)  # the server has set up its stop event
            live.stop()
            await running

    return asyncio.run(main())


async def until_closed(reader: asyncio.StreamReader) -> list[dict]:
    """Every message until the server closes the connection."""
    seen = []
    while line := await reader.readline():
        seen.append(json.loads(line))
    return seen


def test_a_connection_that_never_authenticates_is_closed(monkeypatch):
    async def client(port: int) -> list[dict]:
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        try:
            return await until_closed(reader)
        finally:
            writer.close()

    seen = serve_with(monkeypatch, client, token="s3cret", AUTH_TIMEOUT_S=0.2)
    assert seen == [{"type": "hello", "auth_required": True}]


def test_a_silent_admitted_client_is_closed(monkeypatch):
    async def client(port: int) -> list[dict]:
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        writer.write(b'{"id": 1, "cmd": "state"}\n')
        try:
            return await until_closed(reader)
        finally:
            writer.close()

    seen = serve_with(monkeypatch, client, IDLE_TIMEOUT_S=0.3)
    assert [m["type"] for m in seen] == ["hello", "reply", "reply"]
    assert seen[1]["ok"] and seen[-1] == {
        "type": "reply",
        "id": None,
        "ok": False,
        "reason": "idle too long: closing",
    }


def test_admitted_clients_are_capped(monkeypatch):
    async def client(port: int) -> list[dict]:
        connections = [await asyncio.open_connection("127.0.0.1", port) for _ in range(3)]
        answers = []
        for i, (reader, writer) in enumerate(connections):
            await reader.readline()  # hello (none is evicted: 3 pending of 64)
            writer.write(b'{"id": %d, "cmd": "state"}\n' % i)
            answers.append(json.loads(await reader.readline()))
        assert await connections[2][0].readline() == b"", "the third is closed"
        for _, writer in connections:
            writer.close()
        return answers

    first, second, third = serve_with(monkeypatch, client, MAX_CLIENTS=2)
    assert first["ok"] and second["ok"]
    assert third == {"type": "reply", "id": None, "ok": False, "reason": "too many clients (2)"}


def test_a_request_flood_is_cut_off(monkeypatch):
    async def client(port: int) -> list[dict]:
        reader, writer = await asyncio.open_connection("127.0.0.1", port)
        writer.write(b'{"cmd": "state"}\n' * 50)
        try:
            return await until_closed(reader)
        finally:
            writer.close()

    seen = serve_with(monkeypatch, client, REQUEST_BURST=10, REQUESTS_PER_S=0.001)
    replies = [m for m in seen if m["type"] == "reply"]
    assert len(replies) == 11
    assert replies[-1]["reason"] == "too many requests: closing"


def test_a_new_connection_evicts_the_oldest_pending_one(monkeypatch):
    async def client(port: int) -> list[dict]:
        connections, hellos = [], []
        for _ in range(3):  # one after the other: each has its hello before the next comes
            connections.append(await asyncio.open_connection("127.0.0.1", port))
            hellos.append(json.loads(await connections[-1][0].readline()))
        oldest, _ = connections[0]
        assert await oldest.readline() == b"", "evicted"
        reader, writer = connections[2]
        writer.write(b'{"id": 7, "cmd": "auth", "token": "s3cret"}\n')
        answer = json.loads(await reader.readline())
        for _, w in connections:
            w.close()
        return [*hellos, answer]

    *hellos, answer = serve_with(monkeypatch, client, token="s3cret", MAX_PENDING=2)
    assert hellos == [{"type": "hello", "auth_required": True}] * 3
    assert answer == {"type": "reply", "id": 7, "ok": True, "reason": "authorised"}
