"""Many sessions as one dataset: a comparison table and lazy frames with a ``session_id``.

Sessions are loaded one at a time (memory stays that of one session); with a
folder, every session's tables are written as Parquet under
``FOLDER/data/TABLE/SESSION.parquet`` and :meth:`Dataset.scan` reads them back
lazily, so hundreds of sessions can be queried without loading them all.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path

import polars as pl
from oimi.analysis.load import SessionData, load_session
from oimi.analysis.metrics import SessionMetrics, Verdicts, session_metrics, session_run_name
from oimi.pipeline.errors import LocatedError
from oimi.recorder.errors import RecordingError

SESSION_ID = "session_id"


class AnalysisError(LocatedError):
    """Nothing to analyse: a missing path or a folder without recordings."""


def recordings(paths: Iterable[str | os.PathLike[str]]) -> list[Path]:
    """The MCAP files named, folders expanded to their ``*.mcap`` files (recursive, sorted)."""
    found: list[Path] = []
    for raw in paths:
        path = Path(raw)
        if path.is_dir():
            inside = sorted(path.rglob("*.mcap"))
            if not inside:
                raise AnalysisError("no .mcap recordings in this folder", source=str(path))
            found += inside
        elif path.exists():
            found.append(path)
        else:
            raise AnalysisError("no such file or folder", source=str(path))
    return found


def safe_name(table: str) -> str:
    """A table or session id as a file name (``/world/state`` -> ``world_state``)."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", table.strip("/")) or "table"


class Dataset:
    """Sessions analysed together: ``comparison`` (one row per session) and :meth:`scan`."""

    def __init__(
        self,
        *,
        comparison: pl.DataFrame,
        folder: Path | None,
        frames: dict[str, list[pl.LazyFrame]],
        skipped: Sequence[RecordingError] = (),
    ):
        self.comparison = comparison
        self.folder = folder
        self._frames = frames
        self.skipped = tuple(skipped)
        """The recordings of several that could not be read at all, each with why."""

    @property
    def sessions(self) -> list[str]:
        return self.comparison[SESSION_ID].to_list()

    def tables(self) -> list[str]:
        return sorted(self._frames)

    def scan(self, table: str) -> pl.LazyFrame:
        """One table (a metric such as ``proximity`` or, with a folder, a topic such as
        ``/world/state``) across every session, with a ``session_id`` column."""
        if table not in self._frames:
            raise KeyError(f"no table {table!r}; tables: {', '.join(self.tables())}")
        if self.folder is not None:
            return pl.scan_parquet(self.folder / "data" / safe_name(table) / "*.parquet")
        return pl.concat(self._frames[table], how="diagonal_relaxed")


def build_dataset(
    paths: Sequence[str | os.PathLike[str]],
    *,
    folder: Path | None = None,
    on_session: Callable[[SessionData, SessionMetrics], None] | None = None,
    verdicts: Callable[[Path], Verdicts | None] | None = None,
) -> Dataset:
    """Load and measure every recording in ``paths`` (files or folders), one at a time.

    ``on_session`` is called with each session (e.g. to write its report); ``verdicts``
    checks a recording's expectations (``analysis`` cannot load scenarios itself). Without
    ``folder`` only the metric tables are kept (in memory); with it, the topic
    tables are also written and scannable. Of several recordings, one that cannot be read
    at all (nothing recoverable, another format version) is left out and listed in
    ``Dataset.skipped``; one alone, or every one, raises its ``RecordingError``.
    """
    rows: list[pl.DataFrame] = []
    frames: dict[str, list[pl.LazyFrame]] = {}
    seen: set[str] = set()
    skipped: list[RecordingError] = []
    files = recordings(paths)
    for path in files:
        try:
            data = load_session(path, stream=True)
        except RecordingError as error:
            if len(files) == 1 or len(skipped) + 1 == len(files):
                raise
            skipped.append(error)
            continue
        data.session_id = session_run_name(data)
        if data.session_id in seen:
            data.session_id = f"{data.session_id}@{path.stem}"
        seen.add(data.session_id)
        metrics = session_metrics(data, verdicts(path) if verdicts is not None else None)
        if on_session is not None:
            on_session(data, metrics)
        tables = dict(metrics.tables)
        if folder is not None:
            tables.update(data.tables)
            if data.streamed is not None:
                tables["samples"] = data.streamed.samples.frame()
        for name, frame in tables.items():
            tagged = frame.with_columns(pl.lit(data.session_id).alias(SESSION_ID)).select(
                SESSION_ID, pl.exclude(SESSION_ID)
            )
            if folder is not None:
                target = folder / "data" / safe_name(name)
                target.mkdir(parents=True, exist_ok=True)
                tagged.write_parquet(target / f"{safe_name(data.session_id)}.parquet")
                frames.setdefault(name, [])
            else:
                frames.setdefault(name, []).append(tagged.lazy())
        rows.append(metrics.summary.with_columns(pl.lit(str(path)).alias("path")))
        del data, metrics, tables
    comparison = pl.concat(rows, how="diagonal_relaxed") if rows else pl.DataFrame()
    return Dataset(comparison=comparison, folder=folder, frames=frames, skipped=skipped)
