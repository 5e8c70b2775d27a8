"""Writing a session's analysis: tables as Parquet and CSV, plots as PNG, an HTML page."""

from __future__ import annotations

import html
from collections.abc import Sequence
from pathlib import Path
from typing import Final

import polars as pl

from analysis.load import SessionData
from analysis.metrics import SessionMetrics
from analysis.plots import draw_all

HTML_ROWS: Final = 50
"""Rows of a table shown in the HTML page (the files hold them all)."""

_STYLE: Final = """
body { font-family: sans-serif; margin: 2em; max-width: 1100px; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.85em; }
th, td { border: 1px solid #ccc; padding: 2px 8px; text-align: right; }
th { background: #eee; } td.s { text-align: left; }
img { max-width: 100%; border: 1px solid #ddd; margin: 0.5em 0; }
.warn { color: #a33; }
"""


def write_table(frame: pl.DataFrame, folder: Path, name: str) -> list[Path]:
    """``NAME.parquet`` and ``NAME.csv`` (durations as milliseconds in the CSV)."""
    folder.mkdir(parents=True, exist_ok=True)
    parquet, csv = folder / f"{name}.parquet", folder / f"{name}.csv"
    frame.write_parquet(parquet)
    durations = [c for c, t in frame.schema.items() if isinstance(t, pl.Duration)]
    frame.with_columns(pl.col(c).dt.total_milliseconds().alias(f"{c}_ms") for c in durations).drop(
        durations
    ).write_csv(csv)
    return [parquet, csv]


def html_table(frame: pl.DataFrame, *, rows: int = HTML_ROWS) -> str:
    """A small HTML table of the first ``rows`` rows."""
    head = "".join(f"<th>{html.escape(c)}</th>" for c in frame.columns)
    body = []
    for row in frame.head(rows).iter_rows():
        cells = []
        for value in row:
            text = (
                f"{value:.4g}" if isinstance(value, float) else "" if value is None else str(value)
            )
            cls = ' class="s"' if isinstance(value, str) else ""
            cells.append(f"<td{cls}>{html.escape(text)}</td>")
        body.append(f"<tr>{''.join(cells)}</tr>")
    more = f"<p>({frame.height - rows} more rows in the files)</p>" if frame.height > rows else ""
    return f"<table><tr>{head}</tr>{''.join(body)}</table>{more}"


def transposed(summary: pl.DataFrame) -> pl.DataFrame:
    """A one-row summary as (metric, value) rows."""
    row = summary.row(0, named=True)
    return pl.DataFrame(
        {"metric": list(row), "value": [_text(v) for v in row.values()]},
        schema={"metric": pl.String, "value": pl.String},
    )


def _text(value: object) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return "" if value is None else str(value)


def page(title: str, sections: Sequence[tuple[str, str]], *, warning: str = "") -> str:
    warn = f'<p class="warn">{html.escape(warning)}</p>' if warning else ""
    parts = "".join(f"<h2>{html.escape(h)}</h2>{body}" for h, body in sections)
    return (
        f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
        f"<style>{_STYLE}</style></head><body><h1>{html.escape(title)}</h1>{warn}{parts}</body></html>\n"
    )


def write_session_report(data: SessionData, metrics: SessionMetrics, folder: Path) -> Path:
    """Tables (``tables/``), plots (``plots/``) and ``index.html`` of one session."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, frame in metrics.tables.items():
        write_table(frame, folder / "tables", name)
    plots = draw_all(data, metrics, folder / "plots")
    sections = [("summary", html_table(transposed(metrics.summary)))]
    sections += [("plots", "".join(f'<img src="plots/{p.name}" alt="{p.stem}">' for p in plots))]
    sections += [
        (name, html_table(frame)) for name, frame in metrics.tables.items() if name != "summary"
    ]
    warning = f"damaged recording: {data.recovery}" if data.recovery is not None else ""
    index = folder / "index.html"
    index.write_text(page(f"oimi session {data.session_id}", sections, warning=warning))
    return index


def write_comparison_report(
    comparison: pl.DataFrame, folder: Path, *, links: dict[str, str]
) -> Path:
    """``comparison.parquet/csv`` and an ``index.html`` linking each session's page."""
    write_table(comparison, folder, "comparison")
    items = "".join(
        f'<li><a href="{html.escape(href)}">{html.escape(sid)}</a></li>'
        for sid, href in links.items()
    )
    index = folder / "index.html"
    index.write_text(
        page(
            f"oimi sessions ({comparison.height})",
            [("comparison", html_table(comparison, rows=1000)), ("sessions", f"<ul>{items}</ul>")],
        )
    )
    return index
