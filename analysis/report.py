"""Writing analyses for people: one offline HTML file per session and one comparison page
(plots embedded as PNG data, readable values, a glossary), plus the tables as Parquet/CSV."""

from __future__ import annotations

import base64
import html
import os
from collections.abc import Sequence
from datetime import timedelta
from pathlib import Path
from typing import Final

import polars as pl
from oimi.analysis.compare import AGGREGATED, group_runs, swept_parameters
from oimi.analysis.load import SessionData
from oimi.analysis.metrics import SessionMetrics
from oimi.analysis.plots import comparison_plot, draw_all, png

HTML_ROWS: Final = 50
"""Rows of a table shown in the HTML page (the files hold them all)."""

GLOSSARY: Final[dict[str, tuple[str, str]]] = {
    "run": (
        "",
        "The run's one name: scenario, parameter values and seed (SCENARIO-KEY=VALUE-sSEED).",
    ),
    "session_id": ("", "The recording's id (scenario and seed)."),
    "scenario": ("", "The scenario that was run."),
    "params": ("", "Parameter values changed from the scenario file (empty: none)."),
    "seed": ("", "The random seed: the same scenario, parameters and seed give the same session."),
    "duration_s": ("s", "Length of the session (simulated time)."),
    "damaged": ("", "Whether the recording file was damaged and only partly analysed."),
    "passed": ("", "Whether every expectation of the scenario was met."),
    "expectations_passed": ("", "Expectations of the scenario that were met."),
    "expectations_failed": ("", "Expectations of the scenario that were not met."),
    "activities_started": ("", "Therapy activities that started (idle not counted)."),
    "activities_completed": ("", "Activities that ran to their end."),
    "activities_interrupted": ("", "Activities stopped before their end."),
    "goals_reached": ("", "Goals of the activities that were reached."),
    "goals_failed": ("", "Goals that failed."),
    "goals_interrupted": ("", "Goals cut short by an interruption."),
    "contacts": (
        "",
        "Contact episodes: the robot and a person touching, from first touch to separation (gaps"
        " under 0.2 s merged).",
    ),
    "robot_initiated_contacts": (
        "",
        "Contacts in which the robot moved towards the person faster than the person moved"
        " towards it, just before touching (not those in which another person pushed it"
        " into them: initiator `pushed` in the contacts table).",
    ),
    "pushed_contacts": (
        "",
        "Contacts in which another person pressing into the robot pushed it into this one (its"
        " own drive did not point towards them).",
    ),
    "max_closing_speed_mps": (
        "m/s",
        "The fastest a gap closed just before a contact (robot's and person's speeds towards"
        " each other, summed).",
    ),
    "contact_s": ("s", "Total time in contact (all people)."),
    "closest_human": ("", "The person who came closest to the robot."),
    "min_surface_distance_m": (
        "m",
        "The smallest gap between the robot's and a person's body (surface to surface; 0 ="
        " touching, negative = pressed together).",
    ),
    "intimate_s": (
        "s",
        "Time people spent in the intimate zone (gap under 0.45 m, not touching), summed over"
        " people.",
    ),
    "personal_s": (
        "s",
        "Time people spent in the personal zone (gap 0.45–1.2 m), summed over people.",
    ),
    "safety_interventions": (
        "",
        "Times the safety supervisor slowed or stopped the robot (from /safety; 0 when the"
        " recording has none).",
    ),
    "safety_intervention_s": ("s", "Total time the safety supervisor was limiting the robot."),
    "rule_episodes": (
        "",
        "Rule firing episodes (a rule starting to fire until it stops), housekeeping rules not"
        " counted.",
    ),
    "joystick_takeovers": (
        "",
        "Times the operator held the joystick's safety lock (LB) to drive the robot.",
    ),
    "joystick_s": ("s", "Total time under joystick control."),
    "operator_commands": ("", "Commands the operator gave (add, start, pause...)."),
    "distance_m": ("m", "Distance the robot travelled."),
    "max_speed_mps": ("m/s", "The robot's top speed."),
    "mean_speed_mps": ("m/s", "The robot's average speed (standing still included)."),
    "clamps": ("", "Movement commands cut down to the robot's limits."),
    "rejected_inputs": ("", "Inputs refused as invalid (sensor updates, commands)."),
    "pass": ("%", "Share of the seeds whose run met every expectation."),
    "runs": ("", "Runs (seeds) in the group."),
}
"""Metric -> (unit, meaning), shown on every page."""

_UNITS: Final = {"_mps": "m/s", "_m": "m", "_s": "s"}
"""Units of columns the glossary does not list, from their name's suffix."""

_STYLE: Final = """
body { font-family: system-ui, sans-serif; margin: 1.5em auto; max-width: 1180px; color: #222;
       padding: 0 1em; }
h1 { font-size: 1.5em; } h2 { font-size: 1.15em; border-bottom: 1px solid #ccc; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.5em 0 1.2em; font-size: 0.85em; }
th, td { border: 1px solid #d4d4d4; padding: 3px 8px; text-align: right; vertical-align: top; }
th { background: #f1f1f1; text-align: left; } td.s { text-align: left; }
img { max-width: 100%; margin: 0.4em 0; }
.ok { color: #2b7a0b; font-weight: bold; } .fail { color: #b3261e; font-weight: bold; }
.warn { color: #b3261e; } .cards { display: flex; flex-wrap: wrap; gap: 0.6em; }
.card { border: 1px solid #ddd; border-radius: 6px; padding: 0.5em 0.9em; min-width: 9em; }
.card b { display: block; font-size: 1.25em; } .small { font-size: 0.85em; color: #555; }
.wide { overflow-x: auto; }
"""

KEY_FIGURES: Final = (
    "duration_s",
    "passed",
    "contacts",
    "robot_initiated_contacts",
    "max_closing_speed_mps",
    "min_surface_distance_m",
    "safety_interventions",
    "goals_reached",
    "activities_completed",
    "joystick_takeovers",
)


# ----------------------------------------------------------------------- values


def human_duration(seconds: float) -> str:
    """``72.0`` -> ``1 min 12 s``; ``17.8`` -> ``17.8 s`` (a tenth under a minute, as a
    session's times are read beside verdicts that give them); ``0.02`` -> ``0.02 s``;
    hours when long."""
    if seconds < 0:
        return "-" + human_duration(-seconds)
    if round(seconds, 1) < 60:
        return f"{seconds:.2g} s" if seconds < 1 else f"{seconds:.1f} s".replace(".0 s", " s")
    whole = round(seconds)
    hours, rest = divmod(whole, 3600)
    minutes, secs = divmod(rest, 60)
    parts = [f"{hours} h"] * bool(hours) + [f"{minutes} min"] * bool(minutes or hours)
    return " ".join([*parts, f"{secs} s"] if secs or not parts else parts)


def readable(value: object, column: str = "") -> str:
    """A cell as a person reads it: yes/no, durations, units from the glossary."""
    if value is None:
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, timedelta):
        return human_duration(value.total_seconds())
    column = column.split(" ")[0]  # "contacts mean" -> "contacts"
    if not column.startswith("param:"):
        column = column.split(":")[0]  # "min_surface_distance_m:ada" -> its metric
    unit = GLOSSARY.get(column, ("", ""))[0] or next(
        (u for suffix, u in _UNITS.items() if column.endswith(suffix)), ""
    )
    if column.endswith("_ms") and isinstance(value, int):
        return human_duration(value / 1000)
    if isinstance(value, float):
        if unit == "s" or column.endswith("_s"):
            return human_duration(value)
        if unit == "%":
            return f"{value:.0f} %"
        text = _plain(value) if abs(value) < 1000 else f"{value:,.0f}"
        return f"{text} {unit}".strip()
    return str(value)


def label(column: str) -> str:
    """``min_surface_distance_m`` -> ``min surface distance``: the header a person reads.

    A parameter (``param:robot.max_speed_mps``) keeps its name: it is what ``--param`` takes."""
    if column.startswith("param:"):
        return column
    for suffix in ("_mps", "_ms", "_m", "_s"):
        if column.endswith(suffix):
            column = column.removesuffix(suffix)
            break
    return column.replace("_", " ")


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


def html_table(
    frame: pl.DataFrame, *, rows: int = HTML_ROWS, links: dict[str, str] | None = None
) -> str:
    """An HTML table of the first ``rows`` rows, values made readable, headers explained."""
    if frame.height == 0:
        return '<p class="small">none</p>'
    frame = frame.drop(_shown_twice(frame))
    head = "".join(
        f'<th title="{html.escape(GLOSSARY.get(c, ("", ""))[1])}">{html.escape(label(c))}</th>'
        for c in frame.columns
    )
    body = []
    for row in frame.head(rows).iter_rows(named=True):
        cells = []
        for column, value in row.items():
            text = html.escape(readable(value, column))
            if links and column in ("run", "session_id") and value in links:
                text = f'<a href="{html.escape(links[value])}">{text}</a>'
            cls = ' class="s"' if isinstance(value, str) else ""
            cells.append(f"<td{cls}>{text}</td>")
        body.append(f"<tr>{''.join(cells)}</tr>")
    more = (
        f"<p class='small'>({frame.height - rows} more rows in the table files)</p>"
        if frame.height > rows
        else ""
    )
    return f"<div class='wide'><table><tr>{head}</tr>{''.join(body)}</table></div>{more}"


def _shown_twice(frame: pl.DataFrame) -> list[str]:
    """Columns ``X_ms`` beside a duration column ``X``: the same time, under the same header."""
    durations = {c for c, t in frame.schema.items() if isinstance(t, pl.Duration)}
    return [c for c in frame.columns if c.endswith("_ms") and c.removesuffix("_ms") in durations]


def image(data: bytes, alt: str) -> str:
    """An ``<img>`` with the PNG inside the page (the page works offline, on its own)."""
    encoded = base64.b64encode(data).decode()
    return f'<img src="data:image/png;base64,{encoded}" alt="{html.escape(alt)}">'


def glossary(columns: Sequence[str]) -> str:
    items = "".join(
        f"<tr><td class='s'>{html.escape(label(c))}</td><td"
        f" class='s'>{html.escape(GLOSSARY[c][0])}</td>"
        f"<td class='s'>{html.escape(GLOSSARY[c][1])}</td></tr>"
        for c in dict.fromkeys(columns)
        if c in GLOSSARY
    )
    return f"<table><tr><th>metric</th><th>unit</th><th>meaning</th></tr>{items}</table>"


def page(
    title: str, sections: Sequence[tuple[str, str]], *, lead: str = "", warning: str = ""
) -> str:
    warn = f'<p class="warn">{html.escape(warning)}</p>' if warning else ""
    parts = "".join(f"<h2>{html.escape(h)}</h2>{body}" for h, body in sections)
    return (
        f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head><body>"
        f"<h1>{html.escape(title)}</h1>{lead}{warn}{parts}</body></html>\n"
    )


# ---------------------------------------------------------------------- session


def verdict_table(verdicts: pl.DataFrame) -> str:
    if verdicts.height == 0:
        return (
            '<p class="small">The scenario has no expectations'
            " (or the recording has no scenario attached).</p>"
        )
    rows = "".join(
        f"<tr><td class='{'ok' if ok else 'fail'}'>{'PASS' if ok else 'FAIL'}</td>"
        f"<td class='s'>{html.escape(name)}</td><td class='s'>{html.escape(detail)}</td></tr>"
        for name, ok, detail in verdicts.select("expectation", "passed", "detail").iter_rows()
    )
    return f"<table><tr><th></th><th>expectation</th><th>what was seen</th></tr>{rows}</table>"


SESSION_SECTIONS: Final = (
    ("Contacts", "contacts"),
    ("Closeness per person", "proximity"),
    ("Safety supervisor interventions", "safety_interventions"),
    ("Joystick takeovers", "joystick_takeovers"),
    ("Activities", "activities"),
    ("Goals", "goals"),
    ("Rule episodes (housekeeping rules folded away)", "rule_episodes"),
    ("Rules", "rules"),
    ("Operator commands", "operator"),
    ("Rejected inputs", "rejections"),
)


def session_html(data: SessionData, metrics: SessionMetrics) -> str:
    """The session's page: key figures, verdicts, plots, tables and glossary, self-contained."""
    summary = metrics.summary.row(0, named=True)
    cards = "".join(
        f"<div class='card'><span class='small'>{html.escape(label(k))}</span>"
        f"<b>{html.escape(readable(summary[k], k))}</b></div>"
        for k in KEY_FIGURES
        if k in summary
    )
    plots = draw_all(data, metrics)
    sections = [
        ("Key figures", f"<div class='cards'>{cards}</div>"),
        ("Expectations", verdict_table(metrics["expectations"])),
        ("Timeline", image(plots["timeline"], "timeline")),
        (
            "Closeness",
            image(plots["distance"], "distance") + image(plots["trajectories"], "trajectories"),
        ),
        ("Rules", image(plots["rules"], "rules")),
    ]
    sections += [(title, html_table(metrics[name])) for title, name in SESSION_SECTIONS]
    every = transposed(metrics.summary)
    sections += [
        ("All figures", html_table(every, rows=200)),
        ("Glossary", glossary(metrics.summary.columns)),
    ]
    warning = f"Damaged recording: {data.recovery}" if data.recovery is not None else ""
    lead = f"<p class='small'>Recording {html.escape(os.path.basename(data.path))}</p>"
    return page(
        f"Session {summary.get('run') or data.session_id}", sections, lead=lead, warning=warning
    )


def transposed(summary: pl.DataFrame) -> pl.DataFrame:
    """A one-row summary as (metric, value) rows, values readable."""
    row = summary.row(0, named=True)
    return pl.DataFrame(
        {"metric": [label(k) for k in row], "value": [readable(v, k) for k, v in row.items()]},
        schema={"metric": pl.String, "value": pl.String},
    )


def write_session_report(data: SessionData, metrics: SessionMetrics, folder: Path) -> Path:
    """Tables (``tables/``) and ``index.html`` (one file, plots inside) of one session."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, frame in metrics.tables.items():
        write_table(frame, folder / "tables", name)
    index = folder / "index.html"
    index.write_text(session_html(data, metrics), encoding="utf-8")
    return index


# ------------------------------------------------------------------- comparison


GROUP_TABLE: Final = (
    "contacts",
    "robot_initiated_contacts",
    "max_closing_speed_mps",
    "min_surface_distance_m",
    "intimate_s",
    "safety_interventions",
    "goals_reached",
)
"""The aggregates shown on the comparison page (``groups.csv`` holds them all)."""


def _plain(value: float) -> str:
    """Two decimals at most, no trailing zeros, no ``-0``."""
    text = f"{value:.2f}".rstrip("0").rstrip(".")
    return "0" if text == "-0" else text


def _span(low: float, high: float) -> str:
    """``0.1–0.4``; ``-0.03 to -0.02`` when a dash would run into a minus sign."""
    return f"{_plain(low)}{' to ' if min(low, high) < 0 else '–'}{_plain(high)}"


def group_cells(groups: pl.DataFrame) -> pl.DataFrame:
    """The groups as a person reads them: one cell per metric, ``mean ± spread (min–max)``."""
    keys = [c for c in groups.columns if c.startswith("param:")] or ["params"]
    cells = {
        metric: [
            f"{readable(m, metric)} ± {_plain(sd)} ({_span(lo, hi)})" if m is not None else "–"
            for m, sd, lo, hi in groups.select(
                f"{metric} mean", f"{metric} spread", f"{metric} min", f"{metric} max"
            ).iter_rows()
        ]
        for metric in GROUP_TABLE
        if f"{metric} mean" in groups.columns
    }
    rate = [pl.col("pass rate").alias("pass")] if "pass rate" in groups.columns else []
    head = groups.select("scenario", *keys, "runs", "seeds", *rate)
    return head.with_columns(pl.Series(k, v, dtype=pl.String) for k, v in cells.items())


def write_comparison_report(
    comparison: pl.DataFrame, folder: Path, *, links: dict[str, str]
) -> Path:
    """``comparison.parquet/csv``, ``groups.parquet/csv`` and an ``index.html``: groups of
    scenario × parameters (aggregates over seeds), a plot per metric and swept parameter,
    then every run linking its page (paths relative to the page)."""
    folder.mkdir(parents=True, exist_ok=True)
    if "path" in comparison.columns:  # recordings relative to the page, wherever it was made
        here = folder.resolve()
        comparison = comparison.with_columns(
            pl.col("path").map_elements(
                lambda p: os.path.relpath(Path(p).resolve(), here), return_dtype=pl.String
            )
        )
    write_table(comparison, folder, "comparison")
    groups = group_runs(comparison)
    write_table(groups, folder, "groups")
    swept = swept_parameters(comparison)
    figures = "".join(
        image(png(comparison_plot(groups, metric, parameter)), f"{metric} by {parameter}")
        for parameter in swept
        for metric in AGGREGATED
        if f"{metric} mean" in groups.columns
    )
    sections = [
        ("Groups: scenario × parameters, across seeds", html_table(group_cells(groups), rows=500)),
        (
            "Metrics against each swept parameter",
            figures or "<p class='small'>No parameter was swept.</p>",
        ),
        ("Every run", html_table(comparison.drop("path", strict=False), rows=1000, links=links)),
        ("Glossary", glossary(["pass", "runs", *comparison.columns])),
    ]
    lead = (
        "<p class='small'>Each group's figures: mean ± spread (standard deviation), min and max"
        " over"
        " its seeds; pass rate is the share of seeds whose run met every expectation.</p>"
    )
    index = folder / "index.html"
    index.write_text(
        page(f"Comparison of {comparison.height} runs", sections, lead=lead), encoding="utf-8"
    )
    return index
