"""Cases on a recording: redriving the pipeline from it, and loading it for analysis."""

from __future__ import annotations

from pathlib import Path
from time import perf_counter as clock

from oimi.bench.measure import Case, beside, interleaved, median, per_second


def bench_replay(recording: Path, repetitions: int, run_ticks_per_s: float) -> list[Case]:
    """Redrive beside its floor: reading and decoding the messages it compares (every topic
    but ``/world/state``, which redrive does not read). Redrive is timed as the run is,
    ticking: from its first progress report (``WATCH_TICKS`` ticks in) to its end, so that
    opening the recording and rebuilding its pipeline are set-up, as building the session
    and opening its files are for the run."""
    from oimi.recorder.reader import open_recording
    from oimi.replay.redrive import REDRIVE_TOPICS, redrive

    def ticking() -> tuple[int, float, int]:
        """Redrive: the ticks timed and their seconds (all of them for a session too short
        for a report), and the session's ticks."""
        marks: list[tuple[int, float]] = [(0, clock())]
        comparison = redrive(
            recording, watch=lambda done, _: len(marks) > 1 or marks.append((done, clock()))
        )
        end, ticks = clock(), comparison.ticks
        first, start = marks[1] if len(marks) > 1 and marks[1][0] < ticks else marks[0]
        return ticks - first, end - start, ticks

    def decode_compared() -> int:
        messages = open_recording(recording).iter_messages(REDRIVE_TOPICS)
        return sum(1 for m in messages if m.decoded())

    cases, floors = interleaved(repetitions, ticking, decode_compared)
    ticks = cases[0][1][2]
    rate = median([count / seconds for _, (count, seconds, _) in cases])
    return [
        beside(
            "replay redrive",
            rate,
            "ticks/s",
            "floor: read and decode the messages it compares",
            per_second(ticks, floors),
            target=f">= 3x the run ({3 * run_ticks_per_s:,.0f} ticks/s)",
            extra={"run_ticks_per_s": run_ticks_per_s, "vs_run": rate / run_ticks_per_s},
        )
    ]


def bench_analyse(recording: Path, repetitions: int) -> list[Case]:
    """Loading a session into polars beside a *baseline*: ``polars.read_ndjson`` of each
    topic the loader loads (all but ``/map``), with the same columns: a simpler way to the
    same tables, not a lower bound (the loader streams some topics into summaries)."""
    from io import BytesIO

    import polars as pl
    from mcap.reader import make_reader

    from oimi.analysis.load import DEFAULT_TOPICS, load_session, topic_schema

    def baseline() -> None:
        payloads: dict[str, list[bytes]] = {}
        with recording.open("rb") as stream:
            for _, channel, message in make_reader(stream).iter_messages():
                payloads.setdefault(channel.topic, []).append(message.data)
        for topic in DEFAULT_TOPICS:
            if topic.value in payloads:
                data = BytesIO(b"\n".join(payloads[topic.value]))
                pl.read_ndjson(data, schema=topic_schema(topic))

    cases, baselines = interleaved(repetitions, lambda: load_session(recording), baseline)
    rows = cases[0][1].rows
    return [
        beside(
            "analyse (load into polars)",
            per_second(rows, cases),
            "rows/s",
            "baseline: read_ndjson of its topics",
            per_second(rows, baselines),
            target=">= 300,000 rows/s",
        )
    ]


def bench_analysis_memory(hours: float, folder: Path) -> Case:
    """Peak memory of analysing a synthetic recording of ``hours`` (a working day by default),
    beside the same analysis of a one-minute recording: flat means the same peak."""
    from oimi.analysis.memory import measure_peak_memory

    figure = measure_peak_memory(hours, folder=folder)
    return beside(
        f"analyse memory ({hours:g} h recording)",
        figure.peak_mb,
        "MB peak",
        "baseline: a one-minute recording",
        figure.baseline_mb,
        target="< 300 MB for 8 h",
        extra={"ticks": figure.ticks, "file_mb": figure.file_mb},
    )
