"""Checking a Rerun recording (``.rrd``) before it is shown or copied: Rerun's own reader
must read every chunk of it."""

from __future__ import annotations

import os
import warnings

from oimi.pipeline.texts import clipped
from oimi.recorder.errors import RecordingError

REASON_CHARS = 200
"""Rerun's reasons can hold a whole Arrow error trace: cut to this."""


def check_rrd(path: str | os.PathLike[str]) -> int:
    """The number of chunks of a readable ``.rrd``; ``RecordingError`` naming the file and
    Rerun's reason when it is not a Rerun recording, is truncated or damaged."""
    from rerun.chunk import RrdReader  # Rerun loads slowly: only when an .rrd is given

    name = os.fspath(path)
    chunks = 0
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "no footer": a cut file, found by the scan below
            reader = RrdReader(name)
            if not reader.recordings():
                raise RecordingError("a Rerun file without a recording", source=name)
            for _ in reader.stream().to_chunks():
                chunks += 1
    except (RuntimeError, ValueError, OSError) as error:
        reason = clipped(
            str(error).removeprefix(f"Failed to read RRD file at {name}: "), REASON_CHARS
        )
        raise RecordingError(
            f"damaged or not a Rerun recording ({reason}); {chunks} chunks read before it",
            source=name,
        ) from None
    return chunks
