"""Shared by the live-session tests: ``oimi serve`` in a subprocess and a TCP line client."""

from __future__ import annotations

import contextlib
import json
import os
import re
import resource
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
ROOM = Path(__file__).with_name("live_room.toml")

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def require_browser() -> None:
    """Skip the calling test module when Chromium or Playwright is missing; fail instead
    where ``OIMI_REQUIRE_BROWSER=1`` (CI)."""
    import pytest

    why = None
    if not CHROMIUM.exists():
        why = f"{CHROMIUM} is missing (apt-get install chromium)"
    else:
        try:
            import playwright.sync_api  # noqa: F401
        except ImportError:
            why = "the playwright package is missing (pip install playwright)"
    if why is None:
        return
    if os.environ.get("OIMI_REQUIRE_BROWSER") == "1":
        raise RuntimeError(f"OIMI_REQUIRE_BROWSER=1 but {why}")
    pytest.skip(f"browser tests skipped: {why}", allow_module_level=True)


@dataclass
class Served:
    process: subprocess.Popen[str]
    tcp_port: int | None
    console: str | None
    recording: Path
    output: str = ""
    errors: str = ""
    returncode: int | None = None

    def stop(self) -> None:
        """Ctrl-C, as a therapist ends the session; wait for the recording to close."""
        if self.returncode is not None:
            return
        self.process.send_signal(signal.SIGINT)
        out, err = self.process.communicate(timeout=20)
        self.output += out
        self.errors += err
        self.returncode = self.process.returncode


@contextlib.contextmanager
def served(
    recording: Path, *extra: str, scenario: Path = ROOM, max_files: int | None = None
) -> Iterator[Served]:
    """``oimi serve`` on free ports of 127.0.0.1; stopped (SIGINT) on leaving.
    ``max_files`` lowers the server's open-file limit (RLIMIT_NOFILE)."""

    def limit() -> None:
        if max_files is not None:
            resource.setrlimit(resource.RLIMIT_NOFILE, (max_files, max_files))

    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "oimi",
            "serve",
            str(scenario),
            "--port",
            "0",
            "--http-port",
            "0",
            "-o",
            str(recording),
            *extra,
        ],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
        preexec_fn=limit,
    )
    tcp = console = None
    head = ""
    assert process.stdout is not None
    for line in process.stdout:
        head += line
        if m := re.match(r"app interface: tcp [\d.]+:(\d+)", line):
            tcp = int(m.group(1))
        if m := re.match(r"console: (\S+)", line):
            console = m.group(1)
        if line.startswith("serving"):
            break
    else:
        process.wait(timeout=10)
        raise AssertionError(f"oimi serve did not start: {head}{process.stderr.read()}")
    session = Served(process=process, tcp_port=tcp, console=console, recording=recording)
    session.output = head
    try:
        yield session
    finally:
        if session.returncode is None and process.poll() is None:
            session.stop()
        elif process.poll() is None:
            process.kill()


@dataclass
class LineClient:
    """A TCP client of the App Interface: one JSON object per line each way."""

    sock: socket.socket
    buffer: bytes = b""
    seen: list[dict] = field(default_factory=list)
    next_id: int = 1

    @classmethod
    def connect(cls, port: int) -> LineClient:
        sock = socket.create_connection(("127.0.0.1", port), timeout=5)
        return cls(sock)

    def send_raw(self, data: bytes) -> None:
        self.sock.sendall(data)

    def send(self, **body: object) -> int:
        """Send a request (an id is added); its id."""
        body.setdefault("id", self.next_id)
        self.next_id += 1
        self.send_raw(json.dumps(body).encode() + b"\n")
        return int(body["id"])  # type: ignore[arg-type]

    def read(self, timeout_s: float = 5.0) -> dict:
        deadline = time.monotonic() + timeout_s
        while b"\n" not in self.buffer:
            self.sock.settimeout(max(0.01, deadline - time.monotonic()))
            chunk = self.sock.recv(65536)
            if not chunk:
                raise ConnectionError("closed by the server")
            self.buffer += chunk
        line, self.buffer = self.buffer.split(b"\n", 1)
        message = json.loads(line)
        self.seen.append(message)
        return message

    def reply_to(self, request_id: int, timeout_s: float = 5.0) -> dict:
        deadline = time.monotonic() + timeout_s
        while True:
            m = self.read(max(0.01, deadline - time.monotonic()))
            if m["type"] == "reply" and m.get("id") == request_id:
                return m

    def call(self, **body: object) -> dict:
        return self.reply_to(self.send(**body))

    def state_where(self, check, timeout_s: float = 10.0) -> dict:
        """The first state message (pushed after subscribing) for which ``check`` holds."""
        deadline = time.monotonic() + timeout_s
        while True:
            m = self.read(max(0.01, deadline - time.monotonic()))
            if m["type"] == "state" and check(m["state"]):
                return m["state"]

    def close(self) -> None:
        self.sock.close()


def states(state: dict) -> dict[str, str]:
    """Activity name -> state."""
    return {a["name"]: a["state"] for a in state["activities"]}


def http_status(port: int, request: bytes, timeout_s: float = 5.0) -> str:
    """Send a raw HTTP request to the console's port; the response's status line."""
    with socket.create_connection(("127.0.0.1", port), timeout=timeout_s) as sock:
        sock.sendall(request)
        head = b""
        while b"\r\n" not in head:
            chunk = sock.recv(4096)
            if not chunk:
                break
            head += chunk
    return head.split(b"\r\n", 1)[0].decode()


def upgrade(port: int, *, host: str | None = None, origin: str | None = None) -> bytes:
    """A WebSocket upgrade request for the console's ``/ws``."""
    lines = [
        "GET /ws HTTP/1.1",
        f"Host: {host or f'127.0.0.1:{port}'}",
        "Upgrade: websocket",
        "Connection: Upgrade",
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==",
        "Sec-WebSocket-Version: 13",
    ]
    if origin is not None:
        lines.append(f"Origin: {origin}")
    return ("\r\n".join(lines) + "\r\n\r\n").encode()


def port_of(console: str) -> int:
    """The port of the console's URL."""
    return int(console.rstrip("/").rsplit(":", 1)[1])
