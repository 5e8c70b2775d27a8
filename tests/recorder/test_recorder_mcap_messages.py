"""The sink's message writer writes what mcap's own ``Writer.add_message`` writes, byte for byte."""

from __future__ import annotations

import io

from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.writer import CompressionType, Writer
from oimi.recorder.mcap_sink import _MessageWriter

MESSAGES = st.lists(
    st.tuples(
        st.integers(0, 2),  # channel
        st.integers(0, 10**12),  # time: not always increasing
        st.binary(max_size=300),
    ),
    max_size=60,
)


def written(messages: list[tuple[int, int, bytes]], *, chunk_size: int, fast: bool) -> bytes:
    """A file with three channels (registered in the first chunk, as mcap does) and
    ``messages``, through the sink's writer or mcap's ``add_message``."""
    stream = io.BytesIO()
    writer = Writer(stream, chunk_size=chunk_size, compression=CompressionType.ZSTD)
    adder = _MessageWriter(writer, chunk_size_bytes=chunk_size) if fast else None
    writer.start(profile="", library="test")
    schema = writer.register_schema(name="s", encoding="jsonschema", data=b"{}")
    channels = [
        writer.register_channel(topic=f"/{n}", message_encoding="json", schema_id=schema)
        for n in range(3)
    ]
    for channel, time_ns, payload in messages:
        if adder is None:
            writer.add_message(
                channel_id=channels[channel],
                log_time=time_ns,
                publish_time=time_ns,
                data=payload,
                sequence=0,
            )
        else:
            adder.add(channels[channel], time_ns, payload)
    if adder is not None:
        adder.flush()
    writer.finish()
    return stream.getvalue()


@settings(max_examples=60, deadline=None)
@given(MESSAGES, st.sampled_from([64, 1000, 1 << 20]))
def test_the_sinks_message_writer_writes_what_mcap_writes(messages, chunk_size: int) -> None:
    fast = written(messages, chunk_size=chunk_size, fast=True)
    assert fast == written(messages, chunk_size=chunk_size, fast=False)
