"""Recording a scenario, and rewriting a recording with one thing changed: for the replay
tests' tampered files."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from mcap.records import Attachment, Channel, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import Writer
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.recording import recorded
from oimi.scenarios.session.runner import Session

SHORT = Path(__file__).resolve().parent / "replay_short.toml"
"""A six-second scenario with a script and a generator, joystick, touch and operator input."""

MessageEdit = Callable[[str, int, bytes], bytes | tuple[bytes, ...] | None]
"""(topic, index of the message on its topic, payload) -> new payload, several payloads
(written at the same log time), or None to drop it."""


def rewrite(
    source: Path,
    target: Path,
    *,
    message: MessageEdit | None = None,
    metadata: Callable[[str, dict[str, str]], dict[str, str]] | None = None,
    attachment: Callable[[str, bytes], bytes] | None = None,
) -> None:
    """Copy a recording record by record through the ``mcap`` writer, editing on the way."""
    schemas: dict[int, int] = {}
    channels: dict[int, tuple[int, str]] = {}
    seen: dict[str, int] = {}
    with source.open("rb") as stream, target.open("wb") as out:
        writer = Writer(out)
        writer.start(profile="", library="tamper")
        for record in StreamReader(stream).records:
            match record:
                case Schema() if record.id not in schemas:
                    schemas[record.id] = writer.register_schema(
                        record.name, record.encoding, record.data
                    )
                case Channel() if record.id not in channels:
                    new = writer.register_channel(
                        record.topic,
                        record.message_encoding,
                        schemas.get(record.schema_id, 0),
                        dict(record.metadata),
                    )
                    channels[record.id] = (new, record.topic)
                case Message():
                    channel, topic = channels[record.channel_id]
                    index = seen.get(topic, 0)
                    seen[topic] = index + 1
                    data = record.data if message is None else message(topic, index, record.data)
                    for payload in (data,) if isinstance(data, bytes) else data or ():
                        writer.add_message(
                            channel, record.log_time, payload, record.publish_time, record.sequence
                        )
                case Metadata():
                    data = dict(record.metadata)
                    writer.add_metadata(
                        record.name, data if metadata is None else metadata(record.name, data)
                    )
                case Attachment():
                    data = (
                        record.data if attachment is None else attachment(record.name, record.data)
                    )
                    writer.add_attachment(
                        record.create_time, record.log_time, record.name, record.media_type, data
                    )
        writer.finish()


def record(scenario: Path, target: Path) -> Path:
    """Run ``scenario`` recorded to ``target``."""
    session = Session(load_scenario(scenario))
    with recorded(session, mcap=target, rrd=None):
        session.run()
    return target
