"""The live session's server: one asyncio loop ticks the session to the wall clock and
serves the App Interface (TCP) and the web console (HTTP + WebSocket).

The session itself stays single-threaded and deterministic: requests only queue
operator commands and pad states, which the next tick applies, stamped with that
tick (and so recorded as that tick's inputs). Replies go out after the tick.
Clients never touch the session directly; a client that sends nonsense gets a
refusal, one that stops reading is dropped, one that vanishes is forgotten.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import importlib.resources
import signal
from collections.abc import Callable
from typing import Final

import msgspec
from websockets.asyncio.server import ServerConnection, serve
from websockets.datastructures import Headers
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request as HttpRequest
from websockets.http11 import Response

from pipeline.events import Level, LogEntry, OperatorCommand
from scenarios.live import protocol
from scenarios.live.inputs import JoystickGuard, Pad
from scenarios.live.protocol import (
    MAX_LINE_BYTES,
    OPERATOR_REQUESTS,
    Hello,
    ProtocolError,
    Reply,
    StateMessage,
    decode_request,
    encode_message,
)
from scenarios.live.view import LiveView
from scenarios.recording import scene_of
from scenarios.runner import Session

OUT_QUEUE: Final = 256
"""Messages waiting for a client; one that falls this far behind is dropped."""
WRITE_TIMEOUT_S: Final = 5.0
"""A client that takes longer than this to accept data is dropped."""
FRAME_PERIOD_MS: Final = 100
"""The live view's frame period (10 Hz)."""
MAX_LAG_S: Final = 1.0
"""Further behind the wall clock than this, the session stops catching up and re-paces."""

WEB_FILES: Final = {
    "/": ("index.html", "text/html; charset=utf-8"),
    "/index.html": ("index.html", "text/html; charset=utf-8"),
    "/console.js": ("console.js", "text/javascript; charset=utf-8"),
    "/console.css": ("console.css", "text/css; charset=utf-8"),
}
WS_PATH: Final = "/ws"


class ServeConfig(msgspec.Struct, frozen=True, kw_only=True):
    """Where and how long to serve."""

    host: str = "127.0.0.1"
    tcp_port: int | None = 7070
    """The App Interface's port (0: any free one); None: no TCP interface."""
    http_port: int | None = 8080
    """The web console's port (0: any free one); None: no console."""
    token: str | None = None
    """When set, every client must send ``{"cmd": "auth", "token": ...}`` first."""
    duration_s: float | None = None
    """Stop after this much session time; None: run until stopped."""


class Addresses(msgspec.Struct, frozen=True, kw_only=True):
    """Where the server listens, once it does."""

    tcp: tuple[str, int] | None = None
    console: str | None = None
    """The web console's URL."""


class _Client:
    """One connection: an outgoing queue drained by its own task (``pump``)."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.queue: asyncio.Queue[bytes | None] = asyncio.Queue(OUT_QUEUE)
        self.open = True
        """Still taking messages; False once finishing or dropped."""
        self.authed = False
        self.subscribed = False
        self.world = False
        self.task: asyncio.Task[None] | None = None

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


class _TcpClient(_Client):
    def __init__(self, name: str, writer: asyncio.StreamWriter) -> None:
        super().__init__(name)
        self.writer = writer

    async def _write(self, data: bytes) -> None:
        self.writer.write(data)
        await self.writer.drain()

    async def _close(self) -> None:
        self.writer.close()

    def _drop(self) -> None:
        self.writer.transport.abort()


class _WsClient(_Client):
    def __init__(self, name: str, connection: ServerConnection) -> None:
        super().__init__(name)
        self.connection = connection

    async def _write(self, data: bytes) -> None:
        await self.connection.send(data[:-1].decode())

    async def _close(self) -> None:
        await self.connection.close()

    def _drop(self) -> None:
        self.connection.transport.abort()


class LiveServer:
    """Ticks ``session`` to the wall clock and serves its operator's interfaces."""

    def __init__(
        self,
        session: Session,
        config: ServeConfig,
        *,
        on_ready: Callable[[Addresses], None] | None = None,
        on_note: Callable[[str], None] | None = None,
    ) -> None:
        self.session = session
        self.config = config
        self.on_ready = on_ready
        self.on_note = on_note
        self.view = LiveView(session.pipeline.handler)
        session.sink.add(self.view)
        self.guard = JoystickGuard()
        self.ticks = 0
        """Ticks run so far."""
        self._clients: list[_Client] = []
        self._pending: list[OperatorCommand] = []
        self._waiting: dict[int, tuple[_Client, protocol.Request]] = {}
        self._stop: asyncio.Event | None = None
        self._last_state = b""
        self._frame_every = max(1, FRAME_PERIOD_MS // session.tick_ms)
        self._counter = 0

    # ---------------------------------------------------------------- lifetime

    def stop(self) -> None:
        """End the session after the current tick (safe from a signal handler)."""
        if self._stop is not None:
            self._stop.set()

    async def run(self) -> int:
        """Serve until stopped or ``duration_s`` has passed; the number of ticks run."""
        loop = asyncio.get_running_loop()
        self._stop = asyncio.Event()
        signals = (signal.SIGINT, signal.SIGTERM)
        for sig in signals:
            loop.add_signal_handler(sig, self.stop)
        tcp = web = None
        try:
            host = self.config.host
            tcp_address = console = None
            if self.config.tcp_port is not None:
                tcp = await asyncio.start_server(
                    self._serve_tcp, host, self.config.tcp_port, limit=MAX_LINE_BYTES + 1
                )
                tcp_address = (host, tcp.sockets[0].getsockname()[1])
            if self.config.http_port is not None:
                web = await serve(
                    self._serve_ws,
                    host,
                    self.config.http_port,
                    process_request=self._static,
                    max_size=MAX_LINE_BYTES,
                    ping_interval=2,
                    ping_timeout=2,
                    close_timeout=1,
                )
                port = next(iter(web.sockets)).getsockname()[1]
                console = f"http://{host}:{port}/"
            if self.on_ready is not None:
                self.on_ready(Addresses(tcp=tcp_address, console=console))
            await self._tick_loop()
        finally:
            for sig in signals:
                loop.remove_signal_handler(sig)
            clients = list(self._clients)
            for client in clients:
                client.finish()
            if clients:
                await asyncio.wait([asyncio.ensure_future(c.wait()) for c in clients], timeout=1)
            if tcp is not None:
                tcp.close()
            if web is not None:
                web.close()
                await web.wait_closed()
            await asyncio.sleep(0)
        return self.ticks

    async def _tick_loop(self) -> None:
        loop = asyncio.get_running_loop()
        tick_s = self.session.tick_ms / 1000
        last = None
        if self.config.duration_s is not None:
            last = round(self.config.duration_s * 1000) // self.session.tick_ms
        start = loop.time()
        assert self._stop is not None
        while not self._stop.is_set() and (last is None or self.ticks < last):
            self._step(self.ticks, now_s=loop.time())
            self.ticks += 1
            delay = start + self.ticks * tick_s - loop.time()
            if delay < -MAX_LAG_S:
                self._note(f"{-delay:.1f} s behind the wall clock: re-pacing")
                start = loop.time() - self.ticks * tick_s
                delay = 0
            if delay > 0:
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self._stop.wait(), delay)
            else:
                await asyncio.sleep(0)

    # ------------------------------------------------------------------- a tick

    def _step(self, tick: int, *, now_s: float) -> None:
        commands, self._pending = self._pending, []
        pad = self.guard.take(now_s=now_s)
        for why in self.guard.released:
            self._note(f"safety lock released: {why}", level=Level.WARNING)
        self.guard.released.clear()
        time_ms = tick * self.session.tick_ms
        joystick = None if pad is None else pad.at(tick=tick, time_ms=time_ms)
        self.session.step(tick, commands=commands, joystick=joystick)
        for command_id, reply in self.view.take_replies().items():
            waiting = self._waiting.pop(command_id, None)
            if waiting is None:
                continue  # a scenario's own command
            client, request = waiting
            catalogue = None
            if isinstance(request, protocol.ListActivities) and reply.ok:
                catalogue = self.session.pipeline.handler.describe()
            client.send(
                Reply(
                    id=request.id, ok=reply.ok, reason=reply.reason, tick=tick, catalogue=catalogue
                )
            )
        self._broadcast_state()
        if tick % self._frame_every == 0:
            self._broadcast_frame()

    def _broadcast_state(self) -> None:
        state = self.view.state()
        key = msgspec.json.encode((state.button, state.activities, state.block))
        if key == self._last_state:
            return
        self._last_state = key
        message = StateMessage(state=state)
        for client in self._clients:
            if client.subscribed:
                client.send(message)

    def _broadcast_frame(self) -> None:
        watchers = [c for c in self._clients if c.subscribed and c.world]
        if not watchers:
            return
        frame = self.view.frame(joystick_engaged=self.session.pipeline.actuator.engaged)
        if frame is not None:
            for client in watchers:
                client.send(frame)

    def _note(self, text: str, *, level: Level = Level.INFO) -> None:
        self.view.note(LogEntry(level=level, source="serve", message=text))
        if self.on_note is not None:
            self.on_note(text)

    # ---------------------------------------------------------------- requests

    def _on_line(self, client: _Client, line: bytes | str) -> None:
        if not line.strip():
            return
        try:
            request = decode_request(line)
        except ProtocolError as error:
            client.send(Reply(id=error.id, ok=False, reason=str(error)))
            return
        self._handle(client, request)

    def _handle(self, client: _Client, request: protocol.AnyRequest) -> None:
        def reply(ok: bool, reason: str = "", **extra: object) -> None:
            client.send(Reply(id=request.id, ok=ok, reason=reason, **extra))  # type: ignore[arg-type]

        token = self.config.token
        if isinstance(request, protocol.Auth):
            if token is None or hmac.compare_digest(request.token.encode(), token.encode()):
                client.authed = True
                return reply(True, "authorised")
            return reply(False, "wrong token")
        if token is not None and not client.authed:
            return reply(False, 'unauthorised: send {"cmd": "auth", "token": ...} first')
        verb = OPERATOR_REQUESTS.get(type(request))
        if verb is not None:
            command = self.session.command(
                verb,
                activity=getattr(request, "activity", ""),
                options=dict(getattr(request, "options", {})),
                position=getattr(request, "position", 0),
            )
            self._pending.append(command)
            self._waiting[command.id] = (client, request)
            return None
        match request:
            case protocol.Subscribe():
                client.subscribed, client.world = True, request.world
                reply(True, "subscribed")
                client.send(StateMessage(state=self.view.state()))
            case protocol.Unsubscribe():
                client.subscribed = client.world = False
                reply(True, "unsubscribed")
            case protocol.GetState():
                reply(True, state=self.view.state())
            case protocol.Joystick():
                pad = Pad(
                    left_x=request.left_x,
                    left_y=request.left_y,
                    right_x=request.right_x,
                    buttons=request.buttons,
                )
                self.guard.receive(client, pad, now_s=asyncio.get_running_loop().time())
                reply(True)
        return None

    # -------------------------------------------------------------- transports

    def _hello(self) -> Hello:
        return Hello(
            scenario=self.session.scenario.name,
            tick_ms=self.session.tick_ms,
            auth_required=self.config.token is not None,
            scene=scene_of(self.session.scenario),
        )

    def _connect(self, client: _Client) -> None:
        self._clients.append(client)
        client.start()
        client.send(self._hello())

    async def _disconnect(self, client: _Client) -> None:
        if client in self._clients:
            self._clients.remove(client)
        self.guard.lost(client)
        client.finish()
        await client.wait()

    async def _serve_tcp(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self._counter += 1
        client = _TcpClient(f"tcp-{self._counter}", writer)
        self._connect(client)
        try:
            while client.open:
                try:
                    line = await reader.readuntil(b"\n")
                except asyncio.IncompleteReadError as end:
                    self._on_line(client, end.partial)
                    break
                except asyncio.LimitOverrunError:
                    client.send(
                        Reply(
                            id=None,
                            ok=False,
                            reason=f"message too long: over {MAX_LINE_BYTES} bytes; closing",
                        )
                    )
                    client.finish()
                    break
                self._on_line(client, line)
        except ConnectionError:
            pass
        finally:
            await self._disconnect(client)

    async def _serve_ws(self, connection: ServerConnection) -> None:
        self._counter += 1
        client = _WsClient(f"ws-{self._counter}", connection)
        self._connect(client)
        try:
            async for message in connection:
                self._on_line(client, message)
                if not client.open:
                    break
        except ConnectionClosed:
            pass
        finally:
            await self._disconnect(client)

    def _static(self, connection: ServerConnection, request: HttpRequest) -> Response | None:
        path = request.path.split("?", 1)[0]
        if path == WS_PATH:
            return None
        if path == "/favicon.ico":
            return connection.respond(204, "")
        entry = WEB_FILES.get(path)
        if entry is None:
            return connection.respond(404, f"not found: {path}\n")
        name, content_type = entry
        body = importlib.resources.files("scenarios.live").joinpath("web", name).read_bytes()
        headers = Headers(
            [
                ("Content-Type", content_type),
                ("Content-Length", str(len(body))),
                ("Cache-Control", "no-store"),
                ("Connection", "close"),
            ]
        )
        return Response(200, "OK", headers, body)
