"""Plots of a session and of a comparison: ``matplotlib.figure.Figure`` objects rendered
by the Agg backend to PNG bytes, without pyplot's global state (safe in threads and servers).
"""

from __future__ import annotations

import io
import math
from typing import Final

import msgspec
import polars as pl
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Rectangle
from oimi.analysis.load import SessionData
from oimi.analysis.metrics import SessionMetrics, end_ms
from oimi.pipeline.proximity import ZONES_M
from oimi.recorder import palette
from oimi.recorder.scene import SceneGeometry
from oimi.recorder.topics import SCENE_ATTACHMENT

DPI: Final = 100
ZONE_COLOURS: Final = {
    "contact": "#e06666",
    "intimate": "#f4a3a3",
    "personal": "#f7d08a",
    "social": "#cfe8c4",
}
INITIATOR_COLOURS: Final = {"robot": "#d1495b", "person": "#edae49", "pushed": "#00798c"}
CONTACT_LABELS: Final = {
    "robot": "contact, robot-initiated",
    "person": "contact, person-initiated",
    "pushed": "contact, robot pushed into them",
}
SAFETY_COLOUR: Final = "#7b2cbf"
OUTCOME_COLOURS: Final = {
    "completed": "#4c9a2a",
    "interrupted": "#d1495b",
    "left": "#8d99ae",
    "running": "#3d7dd8",
    "reached": "#4c9a2a",
    "failed": "#d1495b",
}

PLOTS: Final = ("timeline", "distance", "trajectories", "rules")
"""The plots of a session page, in order."""


def _scene(data: SessionData) -> SceneGeometry | None:
    raw = data.attachments.get(SCENE_ATTACHMENT)
    if raw is None:
        return None
    try:
        return msgspec.json.decode(raw, type=SceneGeometry)
    except msgspec.DecodeError:
        return None


def samples(data: SessionData) -> pl.DataFrame:
    """The streamed positions and gaps (``analysis.stream.Samples``)."""
    assert data.streamed is not None
    return data.streamed.samples.frame()


def person_colours(frame: pl.DataFrame) -> dict[str, str]:
    """Each person's colour from the one palette (as in the room view and the console),
    in order of first appearance."""
    people = palette.PersonColours()
    ordered = (
        frame.filter(pl.col("id") != "robot")
        .sort("time_ms", maintain_order=True)
        .unique("id", keep="first", maintain_order=True)
    )
    return {
        person: palette.hex_colour(people.of(person, kind))
        for person, kind in ordered.select("id", "kind").iter_rows()
    }


def _bar(axes, start_ms: float, seconds: float, y: float, colour: str, alpha: float = 0.9) -> None:
    axes.broken_barh(
        [(start_ms / 1000, max(seconds, 0.1))], (y - 0.3, 0.6), color=colour, alpha=alpha
    )


def trajectories(data: SessionData, metrics: SessionMetrics) -> Figure:
    """The arena from above: obstacles, the robot's and each human's path, contacts."""
    scene = _scene(data)
    figure = Figure(figsize=(7, 5.5))
    axes = figure.subplots()
    if scene is not None:
        axes.add_patch(Rectangle((0, 0), scene.width_m, scene.height_m, fill=False, lw=2))
        for o in scene.obstacles:
            if o.radius_m > 0:
                axes.add_patch(Circle((o.x_m, o.y_m), o.radius_m, color="#bbbbbb"))
            else:
                corner = (o.x_m - o.width_m / 2, o.y_m - o.height_m / 2)
                axes.add_patch(
                    Rectangle(
                        corner,
                        o.width_m,
                        o.height_m,
                        angle=math.degrees(o.angle_rad),
                        rotation_point="center",
                        color="#bbbbbb",
                    )
                )
            axes.annotate(o.id, (o.x_m, o.y_m), ha="center", va="center", fontsize=8)
    frame = samples(data)
    colours = person_colours(frame)
    for (who,), rows in frame.group_by("id", maintain_order=True):
        colour = colours.get(str(who), palette.hex_colour(palette.colour("robot-ink")))
        axes.plot(rows["x_m"], rows["y_m"], color=colour, lw=1.5, label=str(who))
        axes.plot(rows["x_m"][0], rows["y_m"][0], "o", color=colour, ms=5)
        axes.plot(rows["x_m"][-1], rows["y_m"][-1], "s", color=colour, ms=6)
    robot = frame.filter(pl.col("id") == "robot").sort("time_ms")
    starts = metrics["contacts"].select(time_ms="started_ms").sort("time_ms")
    if robot.height and starts.height:
        placed = starts.join_asof(robot, on="time_ms", strategy="nearest")
        axes.plot(
            placed["x_m"], placed["y_m"], "X", color="#d1495b", ms=9, ls="none", label="contact"
        )
    axes.set_aspect("equal")
    axes.set_xlabel("x (m)")
    axes.set_ylabel("y (m)")
    axes.set_title("Where everyone went (● start, ■ end, ✖ contact)")
    axes.legend(loc="upper left", bbox_to_anchor=(1.01, 1), fontsize=8)
    axes.autoscale_view()
    figure.tight_layout()
    return figure


def label_levels(times: list[int], gap: float) -> list[int]:
    """A text level per label (times in order) so that labels on one level are at least
    ``gap`` apart: the first level free, a new one when none is."""
    ends: list[float] = []
    levels = []
    for t in times:
        level = next((i for i, end in enumerate(ends) if t - end >= gap), len(ends))
        if level == len(ends):
            ends.append(t)
        ends[level] = t
        levels.append(level)
    return levels


def timeline(data: SessionData, metrics: SessionMetrics) -> Figure:
    """Activities as bars coloured by outcome, goals as markers with labels that never
    overlap, contacts and safety interventions on their own rows; the legend lists only
    what occurred."""
    spans = metrics["activities"]
    goals = metrics["goals"].sort("time_ms")
    names = list(dict.fromkeys(spans["activity"].to_list() + goals["activity"].to_list()))
    rows = [*names, "contacts", "safety interventions"]
    end = end_ms(data) or 1
    levels = label_levels(goals["time_ms"].to_list(), gap=end / 8)
    depth = max(levels, default=-1) + 1
    figure = Figure(figsize=(11, 1.8 + 0.5 * len(rows) + 0.25 * depth))
    axes = figure.subplots()
    used: dict[str, str] = {}
    for row in spans.iter_rows(named=True):
        colour = OUTCOME_COLOURS.get(row["outcome"], "#999999")
        used[f"activity {row['outcome']}"] = colour
        seconds = (row["ended_ms"] - row["started_ms"]) / 1000
        _bar(
            axes,
            row["started_ms"],
            seconds,
            rows.index(row["activity"]),
            colour,
            0.55 if row["idle"] else 0.9,
        )
    for row in metrics["contacts"].iter_rows(named=True):
        colour = INITIATOR_COLOURS[row["initiator"]]
        used[CONTACT_LABELS[row["initiator"]]] = colour
        _bar(
            axes, row["started_ms"], row["duration"].total_seconds(), rows.index("contacts"), colour
        )
    for row in metrics["safety_interventions"].iter_rows(named=True):
        used["safety intervention"] = SAFETY_COLOUR
        y = rows.index("safety interventions")
        _bar(axes, row["started_ms"], row["duration"].total_seconds(), y, SAFETY_COLOUR)
    for row, level in zip(goals.iter_rows(named=True), levels, strict=True):
        y = rows.index(row["activity"])
        colour = OUTCOME_COLOURS.get(row["outcome"], "#555555")
        used[f"goal {row['outcome']}"] = colour
        axes.plot(row["time_ms"] / 1000, y, "D", color=colour, mec="black", zorder=3)
        axes.annotate(
            row["name"],
            (row["time_ms"] / 1000, y),
            xytext=(3, -12 - 10 * level),
            textcoords="offset points",
            fontsize=7,
            arrowprops={"arrowstyle": "-", "color": "#999999", "lw": 0.6},
        )
    axes.set_yticks(range(len(rows)), rows)
    axes.set_ylim(len(rows) - 0.4, -0.7 - 0.35 * depth)
    axes.set_xlim(0, end / 1000 + 0.5)
    axes.set_xlabel("session time (s)")
    handles = [
        Line2D([], [], marker="D", color=c, mec="black", ls="none")
        if k.startswith("goal")
        else Rectangle((0, 0), 1, 1, color=c)
        for k, c in used.items()
    ]
    if handles:
        axes.legend(handles, list(used), fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1))
    axes.set_title("What happened when")
    figure.tight_layout()
    return figure


def distance(data: SessionData, metrics: SessionMetrics) -> Figure:
    """Each human's surface-to-surface gap to the robot over time, over the zones."""
    frame = samples(data).filter(pl.col("id") != "robot")
    figure = Figure(figsize=(11, 4))
    axes = figure.subplots()
    top = max(float(frame["surface_distance_m"].max() or 0.0), 1.5) * 1.05
    bottom = min(float(frame["surface_distance_m"].min() or 0.0), 0.0) - 0.1
    for name, low, high in ZONES_M[:4]:
        label = "contact (touching)" if name == "contact" else f"{name} ({low}–{high} m)"
        axes.axhspan(
            max(low, bottom), min(high, top), color=ZONE_COLOURS[name], alpha=0.6, label=label
        )
    colours = person_colours(frame)
    for (human,), rows in frame.group_by("id", maintain_order=True):
        axes.plot(
            rows["time_ms"] / 1000,
            rows["surface_distance_m"],
            lw=1.5,
            color=colours[str(human)],
            label=str(human),
        )
    for row in metrics["contacts"].iter_rows(named=True):
        axes.axvline(
            row["started_ms"] / 1000, color=INITIATOR_COLOURS[row["initiator"]], lw=0.8, ls="--"
        )
    axes.set_ylim(bottom, top)
    axes.set_xlim(0, end_ms(data) / 1000)
    axes.set_xlabel("session time (s)")
    axes.set_ylabel("gap to the robot (m)")
    axes.set_title("How close each person came, surface to surface (dashed: a contact starts)")
    axes.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1))
    figure.tight_layout()
    return figure


def rules(data: SessionData, metrics: SessionMetrics) -> Figure:
    """Each (non-housekeeping) rule's firing episodes as bars over time."""
    episodes = metrics["rule_episodes"]
    names = sorted(episodes["rule"].unique().to_list())
    figure = Figure(figsize=(11, 1.4 + 0.4 * max(len(names), 1)))
    axes = figure.subplots()
    for row in episodes.iter_rows(named=True):
        seconds = row["duration"].total_seconds()
        _bar(axes, row["started_ms"], seconds, names.index(row["rule"]), "#3d7dd8")
    if not names:
        axes.text(0.5, 0.5, "no rule fired", transform=axes.transAxes, ha="center")
    axes.set_yticks(range(len(names)), names)
    axes.set_ylim(len(names) - 0.4, -0.6)
    axes.set_xlim(0, end_ms(data) / 1000)
    axes.set_xlabel("session time (s)")
    axes.set_title("When each rule was firing (housekeeping rules folded away)")
    figure.tight_layout()
    return figure


def draw_all(data: SessionData, metrics: SessionMetrics) -> dict[str, bytes]:
    """Every plot of :data:`PLOTS` as PNG bytes, by name."""
    figures = {
        "timeline": timeline,
        "distance": distance,
        "trajectories": trajectories,
        "rules": rules,
    }
    return {name: png(figures[name](data, metrics)) for name in PLOTS}


def png(figure: Figure) -> bytes:
    buffer = io.BytesIO()
    figure.savefig(buffer, dpi=DPI, format="png")
    return buffer.getvalue()


def comparison_plot(groups: pl.DataFrame, metric: str, parameter: str) -> Figure:
    """One metric's mean over seeds (bars: min to max) against one swept parameter,
    a line per scenario."""
    figure = Figure(figsize=(5.4, 3.4))
    axes = figure.subplots()
    for (scenario,), rows in groups.group_by("scenario", maintain_order=True):
        rows = rows.filter(pl.col(parameter).is_not_null()).sort(parameter)
        if rows.height == 0:
            continue
        numbers = rows[parameter].cast(pl.Float64, strict=False)
        xs = numbers.to_list() if numbers.null_count() == 0 else list(range(rows.height))
        mean = rows[f"{metric} mean"]
        low = (mean - rows[f"{metric} min"]).clip(lower_bound=0.0).fill_null(0.0).to_list()
        high = (rows[f"{metric} max"] - mean).clip(lower_bound=0.0).fill_null(0.0).to_list()
        axes.errorbar(
            xs, mean.to_list(), yerr=[low, high], marker="o", capsize=4, label=str(scenario)
        )
        if numbers.null_count():
            axes.set_xticks(xs, rows[parameter].cast(pl.String).to_list())
    axes.set_xlabel(parameter.removeprefix("param:"))
    axes.set_ylabel(metric)
    axes.set_title(f"{metric}\n(mean over seeds; bars: min to max)", fontsize=9)
    axes.legend(fontsize=7)
    figure.tight_layout()
    return figure
