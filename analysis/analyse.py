"""``oimi analyse``'s work: the metric tables of one recording, or the comparison of several,
and with a folder the tables, plots and HTML report written into it."""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NamedTuple

import polars as pl
from oimi.analysis.dataset import build_dataset, recordings, safe_name
from oimi.analysis.load import AnalysisWarning, SessionData
from oimi.analysis.metrics import SessionMetrics, Verdicts
from oimi.analysis.report import write_comparison_report, write_session_report
from oimi.recorder.metadata import RecordingMetadata


class Analysis(NamedTuple):
    """What the recordings gave."""

    comparison: pl.DataFrame
    """A row per session."""
    session: tuple[RecordingMetadata, SessionMetrics] | None
    """The one session's metadata and metrics when one recording was analysed."""
    warnings: list[str]
    """What could not be read as expected (``AnalysisWarning``\\ s)."""
    skipped: list[str]
    """The recordings left out, each as ``PATH: why`` (none could be read)."""


def analyse(
    paths: Sequence[str | os.PathLike[str]],
    *,
    out: Path | None = None,
    verdicts: Callable[[Path], Verdicts | None] | None = None,
    progress: Callable[[int, int, str], None] | None = None,
) -> Analysis:
    """Measure the recordings in ``paths`` (files or folders) one at a time; with ``out``,
    write one recording's report into it, or several's comparison (``index.html``) linking
    each session's report (``sessions/NAME/``) and their tables (``data/``). ``progress``
    hears ``(done, total, session_id)`` as each session is done."""
    files = recordings(paths)
    single = len(files) == 1
    reports: dict[str, str] = {}
    one: tuple[RecordingMetadata, SessionMetrics] | None = None
    done: list[str] = []

    def on_session(data: SessionData, metrics: SessionMetrics) -> None:
        nonlocal one
        if single:
            one = (data.metadata, metrics)
        if out is not None:
            folder = out if single else out / "sessions" / safe_name(data.session_id)
            index = write_session_report(data, metrics, folder)
            reports[data.session_id] = str(index.relative_to(out))
        done.append(data.session_id)
        if progress is not None:
            progress(len(done), len(files), data.session_id)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", AnalysisWarning)
        dataset = build_dataset(
            files,
            folder=None if out is None or single else out,
            on_session=on_session,
            verdicts=verdicts,
        )
    if not single and out is not None:
        write_comparison_report(dataset.comparison, out, links=reports)
    return Analysis(
        comparison=dataset.comparison,
        session=one,
        warnings=[str(warning.message) for warning in caught],
        skipped=[str(error) for error in dataset.skipped],
    )
