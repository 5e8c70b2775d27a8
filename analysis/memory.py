"""Peak memory of analysing a long session: a synthetic recording of any length, analysed in a
fresh process whose peak resident memory is read back (for ``oimi bench``).

The recording has what drives analysis memory: ``/world/state`` (sampled as a run's) with three
people (one bumping into the robot every minute), rule decisions every 5 ticks with a rule
switching on and off, and a ``/safety`` intervention every minute.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Final

import msgspec
from oimi.pipeline.events import (
    BodyState,
    RuleDecision,
    RuleDecisions,
    SafetyIntervention,
    Topic,
    WorldState,
)
from oimi.pipeline.sink import NS_PER_MS
from oimi.pipeline.think import rulecodes
from oimi.recorder.mcap_sink import McapSink

TICK_MS: Final = 20


class MemoryFigure(msgspec.Struct, frozen=True, kw_only=True):
    """One measurement: a recording of ``hours`` analysed with a peak of ``peak_mb``."""

    hours: float
    ticks: int
    file_mb: float
    peak_mb: float
    """Peak resident memory of the analysing process (``VmHWM``), MB."""
    baseline_mb: float
    """Peak of the same process analysing a one-minute recording (imports included), MB."""


def write_safety(sink: McapSink, time_ms: int, **fields: object) -> None:
    """One ``/safety`` event (a ``SafetyIntervention``) at ``time_ms``."""
    event = msgspec.convert(
        {"tick": time_ms // TICK_MS, "time_ms": time_ms, **fields}, SafetyIntervention
    )
    sink.record(Topic.SAFETY, time_ms * NS_PER_MS, event)


def synthetic_recording(path: Path, *, minutes: float) -> int:
    """Writes a synthetic session of ``minutes`` to ``path``; returns its ticks."""
    ticks = round(minutes * 60_000 / TICK_MS)
    metadata = {"scenario": {"name": "synthetic", "seed": "0", "tick_hz": "50"}}
    with McapSink(path, metadata=metadata, foxglove_every_n_ticks=0) as sink:
        for tick in range(ticks):
            now = tick * TICK_MS
            phase = (now % 60_000) / 60_000
            child_x = 1.5 + 2.0 * abs(math.cos(math.pi * phase))
            robot = BodyState(id="robot", kind="robot", x_m=1.0, y_m=2.0, radius_m=0.3)
            humans = (
                BodyState(id="ada", kind="child", x_m=child_x, y_m=2.0, vx_mps=-0.3, radius_m=0.25),
                BodyState(id="ben", kind="child", x_m=4.0, y_m=3.0, radius_m=0.25),
                BodyState(id="tess", kind="therapist", x_m=5.0, y_m=1.0, radius_m=0.3),
            )
            touching = ("ada",) if child_x - 1.0 - 0.55 <= 0.0 else ()
            state = WorldState(
                tick=tick, time_ms=now, robot=robot, humans=humans, contacts=touching
            )
            sink.record(Topic.WORLD_STATE, now * NS_PER_MS, state)
            if tick % 5 == 0:
                decisions = tuple(
                    RuleDecision(rule=name, rulecode=code, fired=fired)
                    for name, code, fired in (
                        ("child_too_close", rulecodes.CHILD_TOO_CLOSE, phase > 0.9),
                        ("attention_lost", rulecodes.ATTENTION_LOST, False),
                        ("kick_starter", rulecodes.KICK_STARTER, True),
                    )
                )
                message = RuleDecisions(tick=tick, time_ms=now, decisions=decisions)
                sink.record(Topic.RULE_DECISIONS, now * NS_PER_MS, message)
            if now % 60_000 == 30_000:
                for offset, phase_name in ((0, "start"), (2_000, "end")):
                    write_safety(
                        sink,
                        now + offset,
                        phase=phase_name,
                        source="script",
                        zone="slow",
                        human="ada",
                        surface_distance_m=0.5,
                        requested=(0.5, 0.0, 0.0),
                        allowed=(0.2, 0.0, 0.0),
                    )
    return ticks


_MEASURE: Final = """
import sys
from oimi.analysis.load import load_session
from oimi.analysis.metrics import session_metrics
metrics = session_metrics(load_session(sys.argv[1], stream=True))
assert metrics.summary.height == 1
# VmHWM, this process's own high-water mark (ru_maxrss would carry the parent's over exec)
with open("/proc/self/status") as status:
    print(next(int(l.split()[1]) for l in status if l.startswith("VmHWM:")) / 1024)
"""


def peak_mb(recording: Path) -> float:
    """Peak resident memory (MB) of a fresh process analysing ``recording``
    (``load_session(stream=True)`` and ``session_metrics``)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    out = subprocess.run(
        [sys.executable, "-c", _MEASURE, str(recording)],
        check=True,
        capture_output=True,
        text=True,
        env=env,
    )
    return float(out.stdout.strip().splitlines()[-1])


def measure_peak_memory(hours: float = 8.0, *, folder: Path | None = None) -> MemoryFigure:
    """Writes a synthetic recording of ``hours`` and measures analysing it (and a one-minute
    one, the baseline). This is what ``oimi bench`` reports as analysis memory."""
    with tempfile.TemporaryDirectory(prefix="oimi-memory-", dir=folder) as temp:
        long, short = Path(temp) / "long.mcap", Path(temp) / "short.mcap"
        ticks = synthetic_recording(long, minutes=hours * 60)
        synthetic_recording(short, minutes=1)
        return MemoryFigure(
            hours=hours,
            ticks=ticks,
            file_mb=round(long.stat().st_size / 2**20, 1),
            peak_mb=round(peak_mb(long), 1),
            baseline_mb=round(peak_mb(short), 1),
        )
