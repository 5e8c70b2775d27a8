"""The MCAP writer case: foxglove-sdk's compiled writer beside the sink's (mcap's Python one).

Both write the same recorded payloads (the run's first ``WRITER_MESSAGES`` messages, every
topic) into memory, zstd chunks of 1 MiB at zstd's default level, log time = publish time
= the recorded time; each writes them twice to show whether its bytes are the same each
time. foxglove-sdk compresses on one thread (``compression_threads=0``): its default, one
thread per physical core, changes the bytes with the number of cores at some levels.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Final

from oimi.bench.measure import Case, beside, interleaved, per_second

WRITER_MESSAGES: Final = 60_000
"""About ten simulated minutes of the bench scenario (1.9 messages a tick)."""
CHUNK_BYTES: Final = 1024 * 1024

Payloads = list[tuple[str, int, bytes]]
Schemas = dict[str, tuple[str, bytes]]


def bench_writers(recording: Path, repetitions: int) -> list[Case]:
    """foxglove-sdk's MCAP writer beside the sink's, on the run's own messages."""
    schemas, payloads = _read(recording)
    cases, floors = interleaved(
        repetitions,
        lambda: _foxglove_sdk(schemas, payloads),
        lambda: _oimi_sink(schemas, payloads),
    )
    ours = [data for _, data in floors]
    theirs = [data for _, data in cases]
    return [
        beside(
            "MCAP writer: foxglove-sdk",
            per_second(len(payloads), cases),
            "messages/s",
            "the sink's writer (mcap, Python)",
            per_second(len(payloads), floors),
            target="adopt only if faster and the same bytes each run",
            extra={
                "messages": float(len(payloads)),
                "same_bytes_each_run": float(len(set(theirs)) == 1),
                "sink_same_bytes_each_run": float(len(set(ours)) == 1),
                "file_mb": len(theirs[0]) / 1e6,
                "sink_file_mb": len(ours[0]) / 1e6,
            },
        )
    ]


def _read(recording: Path) -> tuple[Schemas, Payloads]:
    from mcap.reader import make_reader

    schemas: Schemas = {}
    payloads: Payloads = []
    with recording.open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages(log_time_order=False):
            if schema is not None:
                schemas.setdefault(channel.topic, (schema.name, schema.data))
            payloads.append((channel.topic, message.log_time, message.data))
            if len(payloads) == WRITER_MESSAGES:
                break
    return schemas, payloads


def _oimi_sink(schemas: Schemas, payloads: Payloads) -> bytes:
    from oimi.recorder.mcap_sink import McapSink

    out = io.BytesIO()
    with McapSink(out, chunk_size_bytes=CHUNK_BYTES) as sink:
        add = sink.add_encoded
        for topic, time_ns, data in payloads:
            add(topic, time_ns, data)
    return out.getvalue()


def _foxglove_sdk(schemas: Schemas, payloads: Payloads) -> bytes:
    import foxglove
    from foxglove.mcap import MCAPCompression, MCAPWriteOptions

    out = io.BytesIO()
    context = foxglove.Context()
    options = MCAPWriteOptions(
        compression=MCAPCompression.Zstd, chunk_size=CHUNK_BYTES, compression_threads=0
    )
    writer = foxglove.open_mcap(out, context=context, writer_options=options)
    channels = {
        topic: foxglove.Channel(
            topic,
            schema=foxglove.Schema(name=name, encoding="jsonschema", data=data),
            message_encoding="json",
            context=context,
        )
        for topic, (name, data) in schemas.items()
    }
    for topic, time_ns, data in payloads:
        channels[topic].log(data, log_time=time_ns)
    writer.close()
    return out.getvalue()
