"""The live session's server: one asyncio loop ticks the session to the wall clock and
serves the App Interface (TCP) and the web console (HTTP + WebSocket).

The session itself stays single-threaded and deterministic: requests only queue
operator commands and pad states, which the next tick applies, stamped with that
tick (and so recorded as that tick's inputs). Replies go out after the tick.
Clients never touch the session directly; a client that sends nonsense gets a
refusal, one that stops reading is dropped, one that vanishes is forgotten.

Closed by default (``docs/security.md``): a connection is *pending* until it is
admitted (with a token: its ``auth`` accepted; without: its first request read)
and learns nothing about the session before; pending connections are few
(:data:`MAX_PENDING`, the oldest evicted for a new one, so a flood cannot keep
the operator out) and short-lived (:data:`AUTH_TIMEOUT_S`); admitted ones are
capped (:data:`MAX_CLIENTS`), idle ones closed (:data:`IDLE_TIMEOUT_S`) and each
is rate-limited. Wrong tokens are answered ever later and cut off. The console's
WebSocket takes only the console's own origin and ``Host``; the TCP port closes
a connection that speaks HTTP.

Long module: one asyncio server whose tick, TCP and WebSocket transports share
the connection state; it moves under ``oimi/`` with the live console (issue 17) and splits there.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import importlib.resources
import signal
import sys
from collections.abc import Callable
from typing import Any, Final

import msgspec
from websockets.asyncio.server import ServerConnection, serve
from websockets.datastructures import Headers
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request as HttpRequest
from websockets.http11 import Response

from oimi.live import protocol
from oimi.live.connections import (
    HTTP_LINE,
    Addresses,
    Client,
    ConsoleConnection,
    Gate,
    Listeners,
    ServeConfig,
    ServeError,
    TcpClient,
    WsClient,
    console_refusal,
    is_loopback,
    listen,
    quiet_logger,
    url_host,
)
from oimi.live.inputs import RELEASE_TEXT, JoystickGuard
from oimi.live.protocol import (
    MAX_LINE_BYTES,
    Hello,
    ProtocolError,
    Reply,
    StateMessage,
    decode_request,
)
from oimi.live.view import LiveView
from oimi.pipeline.events import Level, LogEntry
from oimi.pipeline.operator.commands import Command, ListActivities, OperatorCommand
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.session.info import SessionInfo, with_fields
from oimi.scenarios.session.recording import scene_of
from oimi.scenarios.session.runner import Session
from oimi.scenarios.session.watchdog import watching

__all__ = [
    "Addresses",
    "Listeners",
    "LiveServer",
    "ServeConfig",
    "ServeError",
    "is_loopback",
    "listen",
]

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

MAX_PENDING: Final = 64
"""Connections not yet admitted (both ports); a new one evicts the oldest beyond this."""
MAX_CLIENTS: Final = 16
"""Admitted connections; one more is refused."""
AUTH_TIMEOUT_S: Final = 5.0
"""A pending connection is closed after this long (send ``auth`` or a request first)."""
IDLE_TIMEOUT_S: Final = 300.0
"""An admitted connection that sends nothing for this long is closed."""
MAX_AUTH_FAILURES: Final = 3
"""Wrong tokens on one connection before it is closed."""
AUTH_DELAY_S: Final = 0.25
"""The delay before answering an ``auth`` after one earlier failure from the same address;
it doubles with each further failure, up to :data:`MAX_AUTH_DELAY_S` (reset by a success)."""
MAX_AUTH_DELAY_S: Final = 4.0
MAX_FAILING_ADDRESSES: Final = 4096
"""Addresses whose failures are remembered (the oldest forgotten first)."""


class LiveServer:
    """Ticks ``session`` to the wall clock and serves its operator's interfaces."""

    def __init__(
        self,
        session: Session,
        config: ServeConfig,
        *,
        on_ready: Callable[[Addresses], None] | None = None,
        on_note: Callable[[str], None] | None = None,
        info: SessionInfo | None = None,
    ) -> None:
        self.session = session
        self.info = info
        """The session record (its fields as the console last set them), if it keeps one."""
        self.config = config
        self.on_ready = on_ready
        self.on_note = on_note
        self.view = LiveView(session.pipeline.handler)
        session.sink.add(self.view)
        self.guard = JoystickGuard()
        self.ticks = 0
        """Ticks run so far."""
        self._clients: list[Client] = []
        self._gate = Gate(MAX_PENDING)
        self._pending: list[OperatorCommand] = []
        self._waiting: dict[int, tuple[Client, OperatorCommand]] = {}
        self._stop: asyncio.Event | None = None
        self._last_state = b""
        self._frame_every = max(1, FRAME_PERIOD_MS // session.tick_ms)
        self._sweep_every = max(1, 1000 // session.tick_ms)
        self._counter = 0
        self._released = ""
        self._auth_failures: dict[str, int] = {}
        """Wrong tokens per peer address since its last accepted one."""
        self._console_port = 0
        self._last_error_s = -1.0

    # ---------------------------------------------------------------- lifetime

    def stop(self) -> None:
        """End the session after the current tick (safe from a signal handler)."""
        if self._stop is not None:
            self._stop.set()

    async def run(self, listeners: Listeners | None = None) -> int:
        """Serve until stopped or ``duration_s`` has passed; the number of ticks run.

        ``listeners`` are the ports bound by :func:`listen` (bound here when None)."""
        loop = asyncio.get_running_loop()
        loop.set_exception_handler(self._loop_error)
        self._stop = asyncio.Event()
        signals = (signal.SIGINT, signal.SIGTERM)
        for sig in signals:
            loop.add_signal_handler(sig, self.stop)
        listeners = listeners or listen(self.config)
        tcp = web = None
        try:
            tcp_address = console = None
            if listeners.tcp is not None:
                tcp = await asyncio.start_server(
                    self._serve_tcp, sock=listeners.tcp, limit=MAX_LINE_BYTES + 1
                )
                tcp_address = (self.config.host, listeners.tcp.getsockname()[1])
            if listeners.http is not None:
                self._console_port = listeners.http.getsockname()[1]
                gate = self._gate
                connection_type = type("ConsoleConnection", (ConsoleConnection,), {"gate": gate})
                web = await serve(
                    self._serve_ws,
                    sock=listeners.http,
                    process_request=self._static,
                    max_size=MAX_LINE_BYTES,
                    ping_interval=2,
                    ping_timeout=2,
                    close_timeout=1,
                    open_timeout=AUTH_TIMEOUT_S,
                    logger=quiet_logger(),
                    create_connection=connection_type,
                )
                console = f"http://{url_host(self.config.host)}:{self._console_port}/"
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
            self._gate.expire(float("inf"))
            if tcp is not None:
                tcp.close()
            if web is not None:
                web.close()
                await web.wait_closed()
            listeners.close()
            await asyncio.sleep(0)
        return self.ticks

    def _loop_error(self, loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
        """An error inside asyncio (out of file descriptors while accepting...): one line,
        at most once a second, never a traceback."""
        now = loop.time()
        if now - self._last_error_s < 1.0:
            return
        self._last_error_s = now
        error = context.get("exception")
        detail = f": {error}" if error is not None else ""
        print(f"note: {context.get('message', 'error')}{detail}", file=sys.stderr, flush=True)

    async def _tick_loop(self) -> None:
        loop = asyncio.get_running_loop()
        tick_s = self.session.tick_ms / 1000
        last = None
        if self.config.duration_s is not None:
            last = round(self.config.duration_s * 1000) // self.session.tick_ms
        start = loop.time()
        assert self._stop is not None
        # a user's code that holds a tick is stopped; a late tick stops a robot at once
        with watching(on_late=self.session.late) as watchdog:
            while not self._stop.is_set() and (last is None or self.ticks < last):
                now = loop.time()
                self._step(self.ticks, now_s=now)
                watchdog.feed()
                if self.ticks % self._sweep_every == 0:
                    self._sweep(now)
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

    def _sweep(self, now_s: float) -> None:
        """Close pending connections past their time and admitted ones idle too long."""
        self._gate.expire(now_s - AUTH_TIMEOUT_S)
        for client in self._clients:
            if client.admitted and client.open and now_s - client.heard_s > IDLE_TIMEOUT_S:
                client.send(Reply(id=None, ok=False, reason="idle too long: closing"))
                client.finish()

    # ------------------------------------------------------------------- a tick

    def _step(self, tick: int, *, now_s: float) -> None:
        commands, self._pending = self._pending, []
        taken = self.guard.take(now_s=now_s)
        time_ms = tick * self.session.tick_ms
        joystick = None
        if taken is not None:
            joystick = taken.pad.at(tick=tick, time_ms=time_ms, release=taken.release)
            if taken.release is not None:
                self._released = RELEASE_TEXT[taken.release]
                self._note(f"safety lock released: {self._released}", level=Level.WARNING)
        self.session.step(tick, commands=commands, joystick=joystick)
        for command_id, reply in self.view.take_replies().items():
            waiting = self._waiting.pop(command_id, None)
            if waiting is None:
                continue  # a scenario's own command
            client, request = waiting
            catalogue = None
            if isinstance(request, ListActivities) and reply.ok:
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
        key = msgspec.json.encode((state.button, state.activities, state.block, state.paused_by))
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
        frame = self.view.frame(
            joystick_engaged=self.session.pipeline.actuator.engaged, released=self._released
        )
        if frame is not None:
            for client in watchers:
                client.send(frame)

    def _note(self, text: str, *, level: Level = Level.INFO) -> None:
        self.view.note(LogEntry(level=level, source="serve", message=text))
        if self.on_note is not None:
            self.on_note(text)

    # ---------------------------------------------------------------- requests

    async def _on_line(self, client: Client, line: bytes | str) -> None:
        if not line.strip():
            return
        if not client.spend(asyncio.get_running_loop().time()):
            client.send(Reply(id=None, ok=False, reason="too many requests: closing"))
            client.finish()
            return
        try:
            request = decode_request(line)
        except ProtocolError as error:
            client.send(Reply(id=error.id, ok=False, reason=str(error)))
            return
        if isinstance(request, protocol.Auth):
            await self._authenticate(client, request)
        elif client.admitted or (self.config.token is None and self._admit(client)):
            self._handle(client, request)
        elif self.config.token is not None:
            client.send(
                Reply(
                    id=request.id,
                    ok=False,
                    reason='unauthorised: send {"cmd": "auth", "token": ...} first',
                )
            )

    def _admit(self, client: Client) -> bool:
        """Let a pending client in when there is room; refuse and close it when not."""
        self._gate.leave(client.gate_key)
        if sum(c.admitted for c in self._clients) >= MAX_CLIENTS:
            client.send(Reply(id=None, ok=False, reason=f"too many clients ({MAX_CLIENTS})"))
            client.finish()
            return False
        client.admitted = True
        return True

    async def _authenticate(self, client: Client, request: protocol.Auth) -> None:
        """Check a token: each earlier failure from the same address delays the answer
        (doubling), and the connection closes at its :data:`MAX_AUTH_FAILURES`-th."""
        token = self.config.token
        if token is None or client.admitted:
            client.send(Reply(id=request.id, ok=True, reason="authorised"))
            if not client.admitted:
                self._admit(client)
            return
        earlier = self._auth_failures.get(client.address, 0)
        if earlier:
            await asyncio.sleep(min(AUTH_DELAY_S * 2 ** (earlier - 1), MAX_AUTH_DELAY_S))
            if not client.open:
                return
        if hmac.compare_digest(request.token.encode(), token.encode()):
            self._auth_failures.pop(client.address, None)
            if self._admit(client):
                client.send(Reply(id=request.id, ok=True, reason="authorised"))
                client.send(self._hello())
            return
        self._auth_failures.pop(client.address, None)
        self._auth_failures[client.address] = earlier + 1  # the newest last
        if len(self._auth_failures) > MAX_FAILING_ADDRESSES:
            del self._auth_failures[next(iter(self._auth_failures))]
        client.failures += 1
        if client.failures >= MAX_AUTH_FAILURES:
            client.send(Reply(id=request.id, ok=False, reason="wrong token: closing"))
            client.finish()
            return
        delay = min(AUTH_DELAY_S * 2**earlier, MAX_AUTH_DELAY_S)
        client.send(
            Reply(
                id=request.id,
                ok=False,
                reason=f"wrong token ({client.failures} of {MAX_AUTH_FAILURES}); "
                f"the next answer comes after {delay:g} s",
            )
        )

    def _handle(self, client: Client, request: protocol.AnyRequest) -> None:
        def reply(ok: bool, reason: str = "", **extra: object) -> None:
            client.send(Reply(id=request.id, ok=ok, reason=reason, **extra))  # type: ignore[arg-type]

        match request:
            case Command():  # the operator's: numbered by the session, applied at the next tick
                command = self.session.command(request)
                self._pending.append(command)
                self._waiting[command.id] = (client, request)
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
                self.guard.receive(client, request.pad, now_s=asyncio.get_running_loop().time())
                reply(True, tick=self.ticks)
            case protocol.SetSession():
                if self.info is None:
                    reply(False, "this session keeps no session record")
                    return
                try:
                    self.info = with_fields(
                        self.info,
                        child=request.child,
                        therapist=request.therapist,
                        notes=request.notes,
                    )
                except ScenarioError as error:
                    reply(False, error.message)
                    return
                reply(True, "session fields saved", session=self._fields())

    # -------------------------------------------------------------- transports

    def _hello(self) -> Hello:
        """The session's hello: only that a token is needed, until it has been given."""
        return Hello(
            scenario=self.session.scenario.name,
            tick_ms=self.session.tick_ms,
            auth_required=self.config.token is not None,
            scene=scene_of(self.session.scenario),
            session=self._fields(),
        )

    def _fields(self) -> protocol.SessionFields | None:
        if self.info is None:
            return None
        return protocol.SessionFields(
            child=self.info.child, therapist=self.info.therapist, notes=self.info.notes
        )

    def _connect(self, client: Client) -> None:
        self._clients.append(client)
        client.start()
        if self.config.token is None:
            client.send(self._hello())
        else:
            client.send(Hello(auth_required=True))

    async def _disconnect(self, client: Client) -> None:
        if client in self._clients:
            self._clients.remove(client)
        self._gate.leave(client.gate_key)
        self.guard.lost(client)
        client.finish()
        await client.wait()

    async def _serve_tcp(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self._counter += 1
        now = asyncio.get_running_loop().time()
        client = TcpClient(f"tcp-{self._counter}", writer, now)
        self._gate.enter(client, now)
        self._connect(client)
        first = True
        try:
            while client.open:
                try:
                    line = await reader.readuntil(b"\n")
                except asyncio.IncompleteReadError as end:
                    if first and HTTP_LINE.match(end.partial):
                        break
                    await self._on_line(client, end.partial)
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
                if first and HTTP_LINE.match(line):
                    client.abort()  # a browser's request: its body is never read
                    break
                first = False
                await self._on_line(client, line)
        except ConnectionError:
            pass
        finally:
            await self._disconnect(client)

    async def _serve_ws(self, connection: ServerConnection) -> None:
        self._counter += 1
        client = WsClient(f"ws-{self._counter}", connection, asyncio.get_running_loop().time())
        client.gate_key = connection
        self._connect(client)
        try:
            async for message in connection:
                await self._on_line(client, message)
                if not client.open:
                    break
        except ConnectionClosed:
            pass
        finally:
            await self._disconnect(client)

    def _static(self, connection: ServerConnection, request: HttpRequest) -> Response | None:
        path = request.path.split("?", 1)[0]
        refused = console_refusal(
            request,
            port=self._console_port,
            allow_origins=self.config.allow_origins,
            websocket=path == WS_PATH,
        )
        if refused is not None:
            return connection.respond(403, f"refused: {refused}\n")
        if path == WS_PATH:
            return None
        if path == "/favicon.ico":
            return connection.respond(204, "")
        entry = WEB_FILES.get(path)
        if entry is None:
            return connection.respond(404, f"not found: {path}\n")
        name, content_type = entry
        body = importlib.resources.files("oimi.live").joinpath("web", name).read_bytes()
        headers = Headers(
            [
                ("Content-Type", content_type),
                ("Content-Length", str(len(body))),
                ("Cache-Control", "no-store"),
                ("Connection", "close"),
            ]
        )
        return Response(200, "OK", headers, body)
