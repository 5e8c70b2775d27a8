"""Re-checking a folder of recordings (``oimi batch --replay DIR``): every ``*.mcap``
redriven on the batch's executors, the outcome tabulated in ``replay.csv``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import NamedTuple

import msgspec
import polars as pl

from oimi.batch.app import executor_for
from oimi.batch.spec import SpecError
from oimi.recorder.errors import RecordingError
from oimi.recorder.outputs import check_output
from oimi.replay.redrive import redrive

REPLAY_RESULTS = "replay.csv"


class ReplayRow(msgspec.Struct, frozen=True, kw_only=True):
    """One recording re-checked: whether the replay matched, and the first divergence."""

    recording: str
    ok: bool
    ticks: int
    """Ticks replayed (0 when the recording could not be replayed)."""
    detail: str


class ReplayReport(NamedTuple):
    """A folder re-checked: a row per recording (in name order) and the table written."""

    folder: Path
    rows: list[ReplayRow]
    table: Path


def replay_recording(path: str) -> ReplayRow:
    """Redrive one recording (a top-level function, so pool and Ray workers can run it)."""
    name = Path(path).name
    try:
        comparison = redrive(path)
    except RecordingError as error:
        return ReplayRow(recording=name, ok=False, ticks=0, detail=str(error))
    d = comparison.divergence
    detail = "identical" if d is None else f"{d.kind} {d.topic} at tick {d.tick}: {d.path}"
    return ReplayRow(recording=name, ok=comparison.ok, ticks=comparison.ticks, detail=detail)


def replay_folder(args: argparse.Namespace) -> ReplayReport:
    """Redrive every ``*.mcap`` of ``--replay`` on the same executors (each one's outcome on
    stderr unless ``--quiet``); the table goes into ``--out``."""
    folder: Path = args.replay
    out_dir = check_output(args.out, folder=True)
    paths = sorted(folder.glob("*.mcap"))
    if not paths:
        raise SpecError("no recordings (*.mcap) in this folder", source=str(folder))
    rows: dict[int, ReplayRow] = {}
    with executor_for(args) as executor:
        for index, row in executor.map(replay_recording, [str(p) for p in paths]):
            rows[index] = row
            if not args.quiet:
                print(f"{'ok' if row.ok else 'DIVERGED'} {row.recording}", file=sys.stderr)
    ordered = [rows[i] for i in range(len(paths))]
    out_dir.mkdir(parents=True, exist_ok=True)
    table = out_dir / REPLAY_RESULTS
    pl.DataFrame([msgspec.structs.asdict(row) for row in ordered]).write_csv(table)
    return ReplayReport(folder=folder, rows=ordered, table=table)
