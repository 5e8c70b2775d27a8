"""Plots of a session as PNG files: ``matplotlib.figure.Figure`` objects rendered by the
Agg backend, without pyplot's global state (safe in threads and servers)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Final

import matplotlib
import msgspec
import polars as pl
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Rectangle

from analysis.load import SessionData
from analysis.metrics import ZONES_M, SessionMetrics, distances, end_ms, fired_rules
from recorder.scene import SceneGeometry
from recorder.topics import SCENE_ATTACHMENT

DPI: Final = 110
ZONE_COLOURS: Final = {"intimate": "#f4a3a3", "personal": "#f7d08a", "social": "#cfe8c4"}
OUTCOME_COLOURS: Final = {
    "completed": "#4c9a2a",
    "interrupted": "#d1495b",
    "left": "#8d99ae",
    "running": "#3d7dd8",
    "reached": "#4c9a2a",
    "failed": "#d1495b",
}

PLOTS: Final = ("trajectories", "timeline", "distance", "rules")
"""The plots :func:`draw_all` writes, as ``NAME.png``."""


def _scene(data: SessionData) -> SceneGeometry | None:
    raw = data.attachments.get(SCENE_ATTACHMENT)
    if raw is None:
        return None
    try:
        return msgspec.json.decode(raw, type=SceneGeometry)
    except msgspec.DecodeError:
        return None


def trajectories(data: SessionData) -> Figure:
    """The arena from above: obstacles, the robot's and each human's path."""
    scene = _scene(data)
    figure = Figure(figsize=(7, 6))
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
    world = data["/world/state"]
    paths = [("robot", world["robot_x_m"], world["robot_y_m"], "black")]
    humans = data["/world/state/humans"]
    colours = matplotlib.colormaps["tab10"]
    for i, ((human,), rows) in enumerate(humans.group_by("id", maintain_order=True)):
        paths.append((str(human), rows["x_m"], rows["y_m"], colours(i)))
    for label, xs, ys, colour in paths:
        if xs.len() == 0:
            continue
        axes.plot(xs, ys, color=colour, lw=1.5, label=label)
        axes.plot(xs[0], ys[0], "o", color=colour, ms=5)
        axes.plot(xs[-1], ys[-1], "s", color=colour, ms=6)
    axes.set_aspect("equal")
    axes.set_xlabel("x (m)")
    axes.set_ylabel("y (m)")
    axes.set_title(f"{data.session_id}: trajectories (o start, ■ end)")
    axes.legend(loc="best", fontsize=8)
    axes.autoscale_view()
    return figure


def timeline(data: SessionData, metrics: SessionMetrics) -> Figure:
    """Activities as bars coloured by outcome, goals as markers on their activity's row."""
    spans = metrics["activities"]
    goals = metrics["goals"]
    names = list(dict.fromkeys(spans["activity"].to_list() + goals["activity"].to_list()))
    figure = Figure(figsize=(10, 1.2 + 0.6 * max(len(names), 1)))
    axes = figure.subplots()
    for row in spans.iter_rows(named=True):
        y = names.index(row["activity"])
        width = (row["ended_ms"] - row["started_ms"]) / 1000
        axes.broken_barh(
            [(row["started_ms"] / 1000, max(width, 0.05))],
            (y - 0.3, 0.6),
            color=OUTCOME_COLOURS.get(row["outcome"], "#999999"),
            alpha=0.5 if row["idle"] else 0.9,
        )
    for outcome, rows in goals.group_by("outcome"):
        axes.scatter(
            rows["time_ms"] / 1000,
            [names.index(a) for a in rows["activity"]],
            marker="D",
            color=OUTCOME_COLOURS.get(str(outcome[0]), "#555555"),
            edgecolor="black",
            zorder=3,
            label=f"goal {outcome[0]}",
        )
    for row in goals.iter_rows(named=True):
        y = names.index(row["activity"])
        axes.annotate(row["name"], (row["time_ms"] / 1000, y + 0.35), fontsize=7, rotation=20)
    axes.set_yticks(range(len(names)), names)
    axes.set_ylim(-0.7, len(names) - 0.3)
    axes.set_xlim(0, end_ms(data) / 1000 + 0.5)
    axes.set_xlabel("simulated time (s)")
    handles = [
        Rectangle((0, 0), 1, 1, color=OUTCOME_COLOURS[o])
        for o in ("completed", "interrupted", "left", "running")
    ]
    labels = ["completed", "interrupted", "left", "running"]
    goal_handles, goal_labels = axes.get_legend_handles_labels()
    axes.legend(handles + goal_handles, labels + goal_labels, fontsize=7, loc="upper right")
    axes.set_title(f"{data.session_id}: activities and goals")
    figure.tight_layout()
    return figure


def distance(data: SessionData) -> Figure:
    """Each human's distance to the robot over time, over the shaded proxemic zones."""
    frame = distances(data)
    figure = Figure(figsize=(10, 4))
    axes = figure.subplots()
    top = max(float(frame["distance_m"].max() or 0.0), ZONES_M[-1][2]) * 1.05
    for name, low, high in ZONES_M:
        axes.axhspan(low, high, color=ZONE_COLOURS[name], alpha=0.6, label=f"{name} < {high} m")
    for (human,), rows in frame.group_by("human", maintain_order=True):
        axes.plot(rows["time_ms"] / 1000, rows["distance_m"], lw=1.5, label=str(human))
    axes.set_ylim(0, top)
    axes.set_xlim(0, end_ms(data) / 1000)
    axes.set_xlabel("simulated time (s)")
    axes.set_ylabel("distance to robot (m, centre to centre)")
    axes.set_title(f"{data.session_id}: distance to the robot")
    axes.legend(fontsize=8, loc="upper right")
    figure.tight_layout()
    return figure


def rules(data: SessionData) -> Figure:
    """Each rule's cumulative count of firings over time."""
    fired = fired_rules(data)
    figure = Figure(figsize=(10, 4))
    axes = figure.subplots()
    for (rule,), rows in fired.group_by("rule", maintain_order=True):
        times = rows["time_ms"] / 1000
        axes.step(
            times, pl.int_range(1, rows.height + 1, eager=True), where="post", label=str(rule)
        )
    if fired.height == 0:
        axes.text(0.5, 0.5, "no rule fired", transform=axes.transAxes, ha="center")
    axes.set_xlim(0, end_ms(data) / 1000)
    axes.set_xlabel("simulated time (s)")
    axes.set_ylabel("times fired (cumulative)")
    axes.set_title(f"{data.session_id}: rules fired")
    if fired.height:
        axes.legend(fontsize=8, loc="upper left")
    figure.tight_layout()
    return figure


def draw_all(data: SessionData, metrics: SessionMetrics, folder: Path) -> list[Path]:
    """Writes every plot of :data:`PLOTS` into ``folder``; returns the files."""
    folder.mkdir(parents=True, exist_ok=True)
    figures = {
        "trajectories": lambda: trajectories(data),
        "timeline": lambda: timeline(data, metrics),
        "distance": lambda: distance(data),
        "rules": lambda: rules(data),
    }
    written = []
    for name in PLOTS:
        figure = figures[name]()
        path = folder / f"{name}.png"
        figure.savefig(path, dpi=DPI)
        written.append(path)
    return written
