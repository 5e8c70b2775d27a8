"""Foxglove live: the recording's channels, schemas and messages over Foxglove's WebSocket
protocol, served on loopback by the official ``foxglove-sdk``.

:class:`FoxgloveLiveSink` is a sink for a running session (``oimi serve --foxglove``):
every event goes out on the channel of its topic with the MCAP's JSON Schema, and
Foxglove's scene, transform and log views are drawn as in the MCAP. Messages are only
encoded for channels a client subscribed to. :func:`serve_recording` streams a
recorded file's channels at the pace they were recorded (``oimi replay --foxglove``).
"""

from __future__ import annotations

import ipaddress
import struct
import time
from collections.abc import Callable
from pathlib import Path
from typing import Final

import foxglove as sdk
import msgspec
from mcap.exceptions import McapError
from mcap.reader import McapReader, make_reader
from mcap.records import Channel, Schema
from mcap.summary import Summary
from oimi.pipeline.events import Event, LogEntries, Topic, WorldState
from oimi.recorder import foxglove
from oimi.recorder.errors import RecordingError
from oimi.recorder.mcap_sink import DEFAULT_FOXGLOVE_EVERY_N_TICKS
from oimi.recorder.scene import SceneGeometry
from oimi.recorder.topics import (
    MESSAGE_ENCODING,
    SCHEMA_ENCODING,
    FoxgloveTopic,
    foxglove_schema,
    schema_data,
    schema_name,
)

DEFAULT_PORT: Final = 8765
"""Foxglove's usual WebSocket port."""
STATIC_SCENE_EVERY_NS: Final = 1_000_000_000
"""The arena and the bodies' scene (sent when it changes) are re-sent once a simulated
second, so that a client that joins late draws them."""


DRAIN_LIMIT_S: Final = 600.0
"""How long ``oimi replay --foxglove`` keeps serving after the last message while a client
is still subscribed: the SDK holds what a slow client has not yet received, and tells
nobody when it has (the protocol has no acknowledgement), so the server stays up until the
clients leave, Ctrl-C, or this."""
POLL_S: Final = 0.05


def loopback_host(host: str) -> str:
    """``host`` if it is a loopback address; anything else is refused (closed by default)."""
    try:
        if host == "localhost" or ipaddress.ip_address(host).is_loopback:
            return host
    except ValueError:
        pass
    raise RecordingError(
        f"the Foxglove server listens on loopback only, not {host!r}"
        " (reach it from elsewhere through an SSH tunnel)",
        source="foxglove",
    )


class FoxgloveServer:
    """A started Foxglove WebSocket server with its own context (channels go only to it)."""

    def __init__(
        self, *, port: int = DEFAULT_PORT, host: str = "127.0.0.1", backlog: int | None = None
    ) -> None:
        """``backlog``: how many messages a client may fall behind before the oldest are
        dropped (the SDK's default, 1024, when None)."""
        self.context = sdk.Context()
        try:
            self._server = sdk.start_server(
                name="oimi",
                host=loopback_host(host),
                port=port,
                context=self.context,
                message_backlog_size=backlog,
            )
        except RuntimeError as error:
            raise RecordingError(
                f"cannot start the Foxglove server on {host}:{port}: {error}", source="foxglove"
            ) from None
        self.host = host
        self._channels: list[sdk.Channel] = []

    @property
    def port(self) -> int:
        return self._server.port

    @property
    def url(self) -> str:
        """The address to give Foxglove's "Open connection" (Foxglove WebSocket)."""
        return f"ws://{self.host}:{self.port}"

    def channel(self, topic: str, schema: str, data: bytes, encoding: str) -> sdk.Channel:
        made = sdk.Channel(
            topic,
            schema=sdk.Schema(name=schema, encoding=SCHEMA_ENCODING, data=data),
            message_encoding=encoding,
            context=self.context,
        )
        self._channels.append(made)
        return made

    def subscribed(self) -> bool:
        """Whether a client is subscribed to one of the channels (a client that leaves
        drops its subscriptions)."""
        return any(channel.has_sinks() for channel in self._channels)

    def wait_while_subscribed(self, *, limit_s: float = DRAIN_LIMIT_S) -> bool:
        """Keep serving until no client is subscribed (True) or ``limit_s`` has passed
        (False): what a client has not yet received is sent meanwhile."""
        end = time.monotonic() + limit_s
        while self.subscribed():
            if time.monotonic() >= end:
                return False
            time.sleep(POLL_S)
        return True

    def close(self) -> None:
        self._server.stop()


class FoxgloveLiveSink:
    """A sink serving a session live to Foxglove: the MCAP's topics, schemas and views.

    ``every_n_ticks`` thins the scene and transform views as in the MCAP (0: none).
    Closed with :meth:`close` (``scenarios.session.recording.recorded`` closes its sinks).
    """

    def __init__(
        self,
        *,
        port: int = DEFAULT_PORT,
        host: str = "127.0.0.1",
        scene: SceneGeometry | None = None,
        every_n_ticks: int = DEFAULT_FOXGLOVE_EVERY_N_TICKS,
    ) -> None:
        self.server = FoxgloveServer(port=port, host=host)
        self._encode = msgspec.json.Encoder().encode
        self._channels: dict[str, sdk.Channel] = {
            topic: self.server.channel(
                topic, schema_name(topic), schema_data(topic), MESSAGE_ENCODING
            )
            for topic in Topic
        }
        if every_n_ticks:
            for fox in FoxgloveTopic:
                title, data = foxglove_schema(fox)
                self._channels[fox] = self.server.channel(fox, title, data, MESSAGE_ENCODING)
        self._views = foxglove.Views(scene, every_n_ticks) if every_n_ticks else None
        self._scene = scene
        self._static_at_ns = 0

    @property
    def url(self) -> str:
        return self.server.url

    def subscribed(self, topic: str) -> bool:
        """Whether a client subscribed to ``topic``."""
        return self._channels[topic].has_sinks()

    def record(self, topic: Topic, time_ns: int, message: Event) -> None:
        self._log(topic, time_ns, message)
        if self._views is None:
            return
        if isinstance(message, WorldState):
            for view_topic, view in self._views.world(message, time_ns):
                self._log(view_topic, time_ns, view)
            if time_ns - self._static_at_ns >= STATIC_SCENE_EVERY_NS:
                self._static_at_ns = time_ns
                if self._scene is not None:
                    arena = foxglove.static_scene(self._scene, time_ns)
                    self._log(FoxgloveTopic.ARENA, time_ns, arena)
                if self._views.last_scene is not None:
                    self._log(FoxgloveTopic.SCENE, time_ns, self._views.last_scene)
        elif isinstance(message, LogEntries):
            for log in foxglove.log_messages(message, time_ns):
                self._log(FoxgloveTopic.LOG, time_ns, log)

    def _log(self, topic: str, time_ns: int, message: object) -> None:
        channel = self._channels[topic]
        if channel.has_sinks():
            channel.log(self._encode(message), log_time=time_ns)

    def close(self) -> None:
        self.server.close()


def serve_recording(
    path: Path,
    server: FoxgloveServer,
    *,
    speed: float = 1.0,
    wait_for_client: Callable[[], bool] | None = None,
) -> int:
    """Stream every channel of a recording (ours and Foxglove's, with their schemas) to
    ``server`` in file order, paced to ``speed`` x the recorded time (0: no pacing).

    ``wait_for_client()`` is polled before the first message until it returns False
    (stop waiting) or a client has subscribed. A damaged file is streamed up to the
    damage. Returns the number of messages sent, as soon as the last is handed to the
    server (a slow client may still be receiving: :meth:`FoxgloveServer.wait_while_subscribed`).
    """
    channels: dict[int, sdk.Channel] = {}

    def advertise(schema: Schema | None, channel: Channel) -> sdk.Channel:
        name, data = (schema.name, schema.data) if schema else ("", b"")
        out = channels[channel.id] = server.channel(
            channel.topic, name, data, channel.message_encoding
        )
        return out

    sent = 0
    with open(path, "rb") as stream:
        reader = make_reader(stream)
        start_wall = start_log = None
        try:
            summary = _summary(reader)
            if summary is not None:  # every channel advertised before the first message
                for channel in summary.channels.values():
                    advertise(summary.schemas.get(channel.schema_id), channel)
            for schema, channel, message in reader.iter_messages(log_time_order=False):
                out = channels.get(channel.id) or advertise(schema, channel)
                if start_wall is None:
                    _wait(channels, wait_for_client)
                    start_wall, start_log = time.monotonic(), message.log_time
                if speed > 0:
                    due = start_wall + (message.log_time - start_log) / 1e9 / speed
                    delay = due - time.monotonic()
                    if delay > 0:
                        time.sleep(delay)
                out.log(message.data, log_time=message.log_time)
                sent += 1
        except (McapError, ValueError, EOFError, struct.error) as error:
            if sent == 0:
                raise RecordingError(f"cannot stream: {error}", source=str(path)) from None
    return sent


def _summary(reader: McapReader) -> Summary | None:
    try:
        return reader.get_summary()
    except (McapError, ValueError, EOFError):
        return None


def _wait(channels: dict[int, sdk.Channel], go_on: Callable[[], bool] | None) -> None:
    """Until a client subscribed to a channel (then a moment for its other subscriptions)."""
    if go_on is None:
        return
    while not any(c.has_sinks() for c in channels.values()):
        if not go_on():
            return
        time.sleep(POLL_S)
    time.sleep(0.2)
