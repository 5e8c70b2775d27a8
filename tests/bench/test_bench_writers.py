"""The MCAP writer case writes the same messages through both writers."""

from __future__ import annotations

from pathlib import Path

from mcap.reader import make_reader

from oimi.bench import writers
from oimi.cli import main

GREETING = Path(__file__).resolve().parents[2] / "scenarios" / "library" / "greeting.toml"


def _messages(data: bytes) -> list[tuple[str, int, int, bytes]]:
    from io import BytesIO

    return [
        (channel.topic, message.log_time, message.publish_time, message.data)
        for _, channel, message in make_reader(BytesIO(data)).iter_messages(log_time_order=False)
    ]


def test_both_writers_write_the_recordings_messages_with_their_times(tmp_path: Path) -> None:
    recording = tmp_path / "greeting.mcap"
    assert main(["run", str(GREETING), "-o", str(recording), "-q"]) == 0
    schemas, payloads = writers._read(recording)
    assert len(payloads) > 100 and "/world/state" in schemas

    ours = _messages(writers._oimi_sink(schemas, payloads))
    theirs = _messages(writers._foxglove_sdk(schemas, payloads))

    expected = [(topic, time_ns, time_ns, data) for topic, time_ns, data in payloads]
    assert ours == expected
    assert theirs == expected
    assert writers._foxglove_sdk(schemas, payloads) == writers._foxglove_sdk(schemas, payloads)
