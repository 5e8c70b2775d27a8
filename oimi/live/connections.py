"""The live server's connections: its configuration, the listening sockets (bound before
any recording opens), one class per kind of client with its outgoing queue and request
budget, the gate of connections not yet admitted, and the console's Host/Origin check.

:class:`oimi.live.server.LiveServer` decides what a connection may do; this module
holds how connections are made, kept, limited and dropped (``docs/security.md``).
"""

from __future__ import annotations

import asyncio
import ipaddress
import logging
import re
import socket
from typing import Any, Final

import msgspec
from websockets.asyncio.server import ServerConnection
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request as HttpRequest

from oimi.live import protocol
from oimi.live.protocol import encode_message
from oimi.pipeline.errors import LocatedError

OUT_QUEUE: Final = 256
"""Messages waiting for a client; one that falls this far behind is dropped."""
WRITE_TIMEOUT_S: Final = 5.0
"""A client that takes longer than this to accept data is dropped."""

REQUESTS_PER_S: Final = 200.0
"""A connection's sustained request rate; beyond its burst it is closed."""
REQUEST_BURST: Final = 1000
BACKLOG: Final = 1024
"""The listening sockets' accept queue."""
HTTP_LINE: Final = re.compile(rb"^[A-Z]{3,16} \S* HTTP/\d|^\x16\x03")
"""An HTTP request line (or a TLS hello): a browser's request to the TCP port."""


class ServeError(LocatedError):
    """The server cannot start as asked (an address in use, no token on an open address)."""


class ServeConfig(msgspec.Struct, frozen=True, kw_only=True):
    """Where and how long to serve."""

    host: str = "127.0.0.1"
    tcp_port: int | None = 7070
    """The App Interface's port (0: any free one); None: no TCP interface."""
    http_port: int | None = 8080
    """The web console's port (0: any free one); None: no console."""
    token: str | None = None
    """When set, every client must send ``{"cmd": "auth", "token": ...}`` first."""
    allow_origins: tuple[str, ...] = ()
    """Web origins (``https://tablet.example:8443``) allowed on the console's WebSocket
    besides the console's own."""
    duration_s: float | None = None
    """Stop after this much session time; None: run until stopped."""


class Addresses(msgspec.Struct, frozen=True, kw_only=True):
    """Where the server listens, once it does."""

    tcp: tuple[str, int] | None = None
    console: str | None = None
    """The web console's URL."""


class Listeners:
    """The server's listening sockets, bound before any recording is opened."""

    def __init__(self, tcp: socket.socket | None, http: socket.socket | None) -> None:
        self.tcp = tcp
        self.http = http

    def close(self) -> None:
        for sock in (self.tcp, self.http):
            if sock is not None:
                sock.close()


def is_loopback(host: str) -> bool:
    """``host`` is a loopback name or address (``127.0.0.1``, ``::1``, ``localhost``)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def listen(config: ServeConfig) -> Listeners:
    """Bind both ports now; a :class:`ServeError` naming the address when one cannot be,
    or when a non-loopback address is asked for without a token."""
    if not is_loopback(config.host) and not config.token:
        raise ServeError(
            f"listening on {config.host} needs --token: anyone who can reach it could "
            "drive the robot",
            source="--host",
        )
    bound: list[socket.socket | None] = []
    try:
        for port in (config.tcp_port, config.http_port):
            bound.append(None if port is None else _bind(config.host, port))
    except ServeError:
        for sock in bound:
            if sock is not None:
                sock.close()
        raise
    return Listeners(bound[0], bound[1])


def _bind(host: str, port: int) -> socket.socket:
    try:
        family = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0][0]
        return socket.create_server((host, port), family=family, backlog=BACKLOG)
    except OSError as error:
        raise ServeError(
            f"cannot listen on {host}:{port}: {error.strerror or error}", source="oimi serve"
        ) from None


class Client:
    """One connection: an outgoing queue drained by its own task (``pump``)."""

    def __init__(self, name: str, address: str, now_s: float) -> None:
        self.name = name
        self.address = address
        self.queue: asyncio.Queue[bytes | None] = asyncio.Queue(OUT_QUEUE)
        self.open = True
        """Still taking messages; False once finishing or dropped."""
        self.admitted = False
        """Authenticated (or, without a token, has sent a request)."""
        self.subscribed = False
        self.world = False
        self.task: asyncio.Task[None] | None = None
        self.since_s = now_s
        self.heard_s = now_s
        self.failures = 0
        """Wrong tokens sent on this connection."""
        self.gate_key: object = self
        """What stands for this connection in the server's gate of pending ones."""
        self._budget = float(REQUEST_BURST)

    def spend(self, now_s: float) -> bool:
        """One request's share of the rate budget; False when it is exhausted."""
        self._budget = min(REQUEST_BURST, self._budget + (now_s - self.heard_s) * REQUESTS_PER_S)
        self.heard_s = now_s
        self._budget -= 1
        return self._budget >= 0

    def start(self) -> None:
        self.task = asyncio.create_task(self._run_pump())

    def send(self, message: protocol.Message) -> None:
        """Queue a message; a client this far behind is dropped."""
        if not self.open:
            return
        try:
            self.queue.put_nowait(encode_message(message))
        except asyncio.QueueFull:
            self.abort()

    def finish(self) -> None:
        """Close once what is queued has been sent."""
        if self.open:
            self.open = False
            try:
                self.queue.put_nowait(None)
            except asyncio.QueueFull:
                self.abort()

    def abort(self) -> None:
        """Drop the connection now."""
        self.open = False
        self._drop()
        if self.task is not None:
            self.task.cancel()

    async def wait(self) -> None:
        """Until the pump has ended."""
        if self.task is not None:
            await asyncio.gather(self.task, return_exceptions=True)

    async def _run_pump(self) -> None:
        try:
            while (data := await self.queue.get()) is not None:
                await asyncio.wait_for(self._write(data), WRITE_TIMEOUT_S)
        except (ConnectionError, ConnectionClosed, TimeoutError):
            self.open = False
            self._drop()
        finally:
            await self._close()

    async def _write(self, data: bytes) -> None:
        raise NotImplementedError

    async def _close(self) -> None:
        raise NotImplementedError

    def _drop(self) -> None:
        raise NotImplementedError


class TcpClient(Client):
    def __init__(self, name: str, writer: asyncio.StreamWriter, now_s: float) -> None:
        peer = writer.get_extra_info("peername")
        super().__init__(name, str(peer[0]) if peer else "?", now_s)
        self.writer = writer

    async def _write(self, data: bytes) -> None:
        self.writer.write(data)
        await self.writer.drain()

    async def _close(self) -> None:
        self.writer.close()

    def _drop(self) -> None:
        self.writer.transport.abort()


class WsClient(Client):
    def __init__(self, name: str, connection: ServerConnection, now_s: float) -> None:
        peer = connection.remote_address
        super().__init__(name, str(peer[0]) if peer else "?", now_s)
        self.connection = connection

    async def _write(self, data: bytes) -> None:
        await self.connection.send(data[:-1].decode())

    async def _close(self) -> None:
        await self.connection.close()

    def _drop(self) -> None:
        self.connection.transport.abort()


class Gate:
    """Connections not yet admitted, oldest first: a new one beyond ``limit`` evicts the
    oldest (so a flood of idle connections cannot keep the operator out)."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self.waiting: dict[Any, float] = {}
        """Connection (anything with ``abort()``) -> when it arrived."""
        self.evicted = 0

    def enter(self, connection: Any, now_s: float) -> None:
        while len(self.waiting) >= self.limit:
            oldest = next(iter(self.waiting))
            del self.waiting[oldest]
            self.evicted += 1
            oldest.abort()
        self.waiting[connection] = now_s

    def leave(self, connection: Any) -> None:
        self.waiting.pop(connection, None)

    def expire(self, before_s: float) -> None:
        """Close every connection that arrived before ``before_s``."""
        for connection, since in list(self.waiting.items()):
            if since < before_s:
                del self.waiting[connection]
                connection.abort()


class ConsoleConnection(ServerConnection):
    """A connection to the console's port, held in the gate until admitted or closed."""

    gate: Gate

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        super().connection_made(transport)
        self.gate.enter(self, asyncio.get_running_loop().time())

    def connection_lost(self, exc: Exception | None) -> None:
        self.gate.leave(self)
        super().connection_lost(exc)

    def abort(self) -> None:
        self.transport.abort()


def quiet_logger() -> logging.Logger:
    """The websockets library's logger, silenced: the server reports what matters itself."""
    logger = logging.getLogger("oimi.serve.websockets")
    logger.propagate = False
    logger.addHandler(logging.NullHandler())
    return logger


def is_address(name: str) -> bool:
    try:
        ipaddress.ip_address(name.strip("[]"))
    except ValueError:
        return False
    return True


def origin_host(origin: str) -> str:
    """``https://tablet.example:8443`` -> ``tablet.example``."""
    rest = origin.split("://", 1)[-1]
    if rest.startswith("["):
        return rest.split("]", 1)[0] + "]"
    return rest.split(":", 1)[0].split("/", 1)[0]


def url_host(host: str) -> str:
    return f"[{host}]" if ":" in host else host


def console_refusal(
    request: HttpRequest, *, port: int, allow_origins: tuple[str, ...], websocket: bool
) -> str | None:
    """Why an HTTP request to the console on ``port`` is refused (None: it is not).

    ``Host`` must name this port by an IP address or ``localhost``, or be an allowed
    origin's host (a DNS name an attacker controls cannot rebind to it); a
    WebSocket's ``Origin`` must be the console's own (``http://`` + ``Host``) or
    allowed with ``--allow-origin``; a request without one is no browser's console.
    """
    host = request.headers.get("Host", "")
    name, _, given = host.rpartition(":") if not host.endswith("]") else (host, "", "")
    if not name:
        name, given = given, ""
    if name not in {origin_host(origin) for origin in allow_origins}:  # a proxy: any port
        if not (is_address(name) or name == "localhost"):
            return f"Host {host!r} is not an address of this console"
        if given and given != str(port):
            return f"Host {host!r} is not this console's port"
    if not websocket:
        return None
    origin = request.headers.get("Origin")
    if origin is None or origin == "null":
        return "a WebSocket needs the console's Origin"
    if origin != f"http://{host}" and origin not in allow_origins:
        return f"Origin {origin!r} is not allowed (see --allow-origin)"
    return None
