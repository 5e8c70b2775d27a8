"""Session metrics: polars tables computed from a loaded session (``analysis.load``).

Every function takes a :class:`~analysis.load.SessionData` and returns a frame;
:func:`session_metrics` gathers them with a one-row ``summary`` used to compare
sessions. Times are simulated milliseconds (``*_ms``) or seconds (``*_s``).
"""

from __future__ import annotations

from typing import Final

import msgspec
import polars as pl

from analysis.load import TIME, SessionData
from pipeline.events import REJECTING_SOURCES, Level, ProgressKind

ZONES_M: Final = (("intimate", 0.0, 0.45), ("personal", 0.45, 1.2), ("social", 1.2, 3.6))
"""Hall's proxemic zones, centre-to-centre distance bands ``[from, to)`` in metres."""

"""``/log`` sources whose warnings mean an input was rejected (as ``scenarios.expectations``)."""

_STARTS: Final = (ProgressKind.LOAD.value, ProgressKind.IDLE.value)
_ENDS: Final = (ProgressKind.END.value, ProgressKind.SWITCH.value)
_OUTCOMES: Final = ("completed", "interrupted")
_GOALS: Final = {
    ProgressKind.GOAL_REACHED.value: "reached",
    ProgressKind.GOAL_FAILED.value: "failed",
    ProgressKind.GOAL_INTERRUPTED.value: "interrupted",
}


def end_ms(data: SessionData) -> int:
    """The last simulated time recorded (on any loaded topic)."""
    last = [t["time_ms"].max() for t in data.tables.values() if t.height]
    return int(max((x for x in last if x is not None), default=0))  # type: ignore[type-var]


def _ms_duration(column: str) -> pl.Expr:
    return pl.col(column).cast(pl.Duration("ms"))


# ---------------------------------------------------------------- activities


def activity_timeline(data: SessionData) -> pl.DataFrame:
    """One row per activity run: selected (operator ``add``), started, ended, outcome.

    Outcome is ``completed`` or ``interrupted`` from the Block Reader's end/switch
    item, ``left`` when another script took over without one (idle escaped),
    ``running`` at the end of the recording.
    """
    items = data["/reader/progress/items"].with_row_index("row")
    marks = items.filter(
        pl.col("kind").is_in(_STARTS)
        | (pl.col("kind").is_in(_ENDS) & pl.col("detail").is_in(_OUTCOMES))
    ).with_columns(span=pl.col("kind").is_in(_STARTS).cum_sum())
    is_end = pl.col("kind").is_in(_ENDS)
    spans = (
        marks.filter(pl.col("span") > 0)
        .group_by("span", maintain_order=True)
        .agg(
            activity=pl.col("activity").first(),
            idle=(pl.col("kind").first() == ProgressKind.IDLE.value),
            started_ms=pl.col("time_ms").first(),
            ended_ms=pl.col("time_ms").filter(is_end).first(),
            outcome=pl.col("detail").filter(is_end).first(),
        )
        .with_columns(next_ms=pl.col("started_ms").shift(-1))
        .with_columns(
            outcome=pl.when(pl.col("outcome").is_not_null())
            .then("outcome")
            .when(pl.col("next_ms").is_not_null())
            .then(pl.lit("left"))
            .otherwise(pl.lit("running")),
            ended_ms=pl.coalesce("ended_ms", "next_ms", pl.lit(end_ms(data))),
        )
    )
    added = (
        data["/operator/commands"]
        .filter(pl.col("verb") == "add")
        .group_by("activity")
        .agg(selected_ms=pl.col("time_ms").min())
    )
    return (
        spans.join(added, on="activity", how="left")
        .with_columns(duration=_ms_duration("ended_ms") - _ms_duration("started_ms"))
        .select("activity", "idle", "selected_ms", "started_ms", "ended_ms", "duration", "outcome")
    )


def goals(data: SessionData) -> pl.DataFrame:
    """Every goal reached, failed or interrupted, in order."""
    return (
        data["/reader/progress/items"]
        .filter(pl.col("kind").is_in(list(_GOALS)))
        .select(
            "time_ms",
            TIME,
            "activity",
            pl.col("path").alias("goal"),
            pl.col("detail").alias("name"),
            pl.col("kind").replace_strict(_GOALS).alias("outcome"),
        )
    )


# --------------------------------------------------------------------- rules


def fired_rules(data: SessionData) -> pl.DataFrame:
    """The fired decisions, each with the activity running when it fired.

    The rules run after the Block Reader in a tick, so the activity running is the one of
    the reader's last progress item at or before that tick (a progress message's own
    ``activity`` is the map's ``currentactivity``, which a rule forcing a switch has
    already set to the activity it switches *to*).
    """
    place = (
        data["/reader/progress/items"]
        .select("tick", "activity")
        .group_by("tick", maintain_order=True)
        .last()
        .sort("tick")
    )
    fired = data["/rules/decisions"].filter("fired").select("tick", "time_ms", TIME, "rule")
    return fired.sort("tick").join_asof(place, on="tick", strategy="backward")


def rules_fired(data: SessionData) -> pl.DataFrame:
    """Per rule: evaluations, times fired, first and last time fired."""
    decisions = data["/rules/decisions"]
    return (
        decisions.group_by("rule")
        .agg(
            evaluated=pl.len(),
            fired=pl.col("fired").sum(),
            first_ms=pl.col("time_ms").filter("fired").min(),
            last_ms=pl.col("time_ms").filter("fired").max(),
        )
        .sort("fired", "rule", descending=[True, False])
    )


def rules_by_activity(data: SessionData) -> pl.DataFrame:
    """Times each rule fired while each activity ran."""
    return (
        fired_rules(data)
        .group_by("activity", "rule")
        .agg(fired=pl.len())
        .sort("activity", "fired", descending=[False, True])
    )


# ------------------------------------------------------------------ actuator


def commands(data: SessionData) -> pl.DataFrame:
    """Actuator commands by channel and source (script, joystick, safety), with clamps."""
    return (
        data["/actuator/commands"]
        .group_by("channel", "source")
        .agg(commands=pl.len(), clamped=pl.col("clamped").sum(), stops=pl.col("stop").sum())
        .sort("channel", "source")
    )


def interventions(data: SessionData) -> pl.DataFrame:
    """Joystick interventions: spans with the safety lock (``LB``) held, and the
    joystick commands issued during each."""
    pad = data["/joystick"].select(
        "time_ms", lock=pl.col("buttons").list.contains("LB").fill_null(False)
    )
    spans = (
        pad.with_columns(
            next_ms=pl.col("time_ms").shift(-1).fill_null(end_ms(data)),
            run=(pl.col("lock") != pl.col("lock").shift(1)).fill_null(True).cum_sum(),
        )
        .group_by("run", maintain_order=True)
        .agg(
            lock=pl.col("lock").first(),
            started_ms=pl.col("time_ms").first(),
            ended_ms=pl.col("next_ms").last(),
        )
        .filter("lock")
        .with_columns(duration=_ms_duration("ended_ms") - _ms_duration("started_ms"))
        .drop("run", "lock")
    )
    joystick = data["/actuator/commands"].filter(pl.col("source") == "joystick")
    counts = (
        spans.join_where(
            joystick.select(cmd_ms="time_ms"),
            pl.col("cmd_ms") >= pl.col("started_ms"),
            pl.col("cmd_ms") <= pl.col("ended_ms"),
        )
        .group_by("started_ms")
        .agg(joystick_commands=pl.len())
    )
    return (
        spans.join(counts, on="started_ms", how="left")
        .with_columns(pl.col("joystick_commands").fill_null(0).cast(pl.UInt32))
        .sort("started_ms")
    )


def safety(data: SessionData) -> pl.DataFrame:
    """The safety supervisor's intervention episodes (``/safety``, one row each): when it
    started and ended (null: still on at the end), the source it first limited, the
    human, whether it reached the stop zone and the closest surface distance it estimated."""
    return (
        data["/safety"]
        .with_columns(episode=(pl.col("phase") == "start").cum_sum())
        .group_by("episode", maintain_order=True)
        .agg(
            started_ms=pl.col("time_ms").first(),
            ended_ms=pl.col("time_ms").filter(pl.col("phase") == "end").first(),
            source=pl.col("source").first(),
            human=pl.col("human").filter(pl.col("human") != "").first(),
            stop=(pl.col("zone") == "stop").any(),
            min_surface_distance_m=pl.col("surface_distance_m").min(),
        )
        .drop("episode")
    )


def operator_commands(data: SessionData) -> pl.DataFrame:
    """Every operator command with its reply (ok, reason) when one was recorded."""
    replies = (
        data["/operator/state/replies"]
        .select("id", "ok", "reason", reply_ms="time_ms")
        .unique("id", keep="first", maintain_order=True)
    )
    return (
        data["/operator/commands"]
        .select("time_ms", "id", "verb", "activity")
        .join(replies, on="id", how="left")
        .sort("time_ms", "id")
    )


# --------------------------------------------------------------------- world


def distances(data: SessionData) -> pl.DataFrame:
    """Per tick and human: centre-to-centre distance to the robot, m."""
    robot = data["/world/state"].select("tick", "robot_x_m", "robot_y_m")
    return (
        data["/world/state/humans"]
        .select("tick", "time_ms", TIME, "id", "kind", "x_m", "y_m")
        .join(robot, on="tick")
        .select(
            "tick",
            "time_ms",
            TIME,
            pl.col("id").alias("human"),
            "kind",
            distance_m=(
                (pl.col("x_m") - pl.col("robot_x_m")) ** 2
                + (pl.col("y_m") - pl.col("robot_y_m")) ** 2
            ).sqrt(),
        )
    )


def _zone_seconds(tick_ms: int) -> list[pl.Expr]:
    """Seconds of samples (one per tick) whose ``distance_m`` lies in each zone."""
    seconds = tick_ms / 1000
    return [
        ((pl.col("distance_m") >= low) & (pl.col("distance_m") < high))
        .sum()
        .mul(seconds)
        .alias(f"{name}_s")
        for name, low, high in ZONES_M
    ]


def proximity(data: SessionData) -> pl.DataFrame:
    """Per human: minimum distance (and when), seconds spent in each of :data:`ZONES_M`."""
    frame = distances(data)
    return (
        frame.group_by("human", maintain_order=True)
        .agg(
            pl.col("kind").first(),
            pl.col("distance_m").min().alias("min_distance_m"),
            pl.col("time_ms").get(pl.col("distance_m").arg_min()).alias("min_at_ms"),
            *_zone_seconds(data.tick_ms),
        )
        .sort("human")
    )


def robot(data: SessionData) -> pl.DataFrame:
    """The robot: distance travelled, maximum and mean speed, commands clamped (one row)."""
    world = data["/world/state"]
    speed = (pl.col("robot_vx_mps") ** 2 + pl.col("robot_vy_mps") ** 2).sqrt()
    step = (pl.col("robot_x_m").diff() ** 2 + pl.col("robot_y_m").diff() ** 2).sqrt()
    figures = world.select(
        distance_m=step.sum(),
        max_speed_mps=speed.max().fill_null(0.0),
        mean_speed_mps=speed.mean().fill_null(0.0),
        contact_ticks=pl.col("contact_count").sum().cast(pl.Int64),
    )
    clamps = data["/actuator/commands"]["clamped"].sum()
    return figures.with_columns(clamps=pl.lit(int(clamps), dtype=pl.Int64))


def rejections(data: SessionData) -> pl.DataFrame:
    """Rejected inputs (``/log`` warnings and errors from the input stages) by source and reason."""
    return (
        data["/log"]
        .filter((pl.col("level") >= int(Level.WARNING)) & pl.col("source").is_in(REJECTING_SOURCES))
        .group_by("source", pl.col("message").alias("reason"))
        .agg(count=pl.len(), first_ms=pl.col("time_ms").min())
        .sort("source", "first_ms")
    )


# ------------------------------------------------------------------- summary


class SessionMetrics(msgspec.Struct, kw_only=True, dict=True):
    """Every metric table of one session, and its one-row ``summary``."""

    session_id: str
    tables: dict[str, pl.DataFrame]

    def __getitem__(self, name: str) -> pl.DataFrame:
        return self.tables[name]

    @property
    def summary(self) -> pl.DataFrame:
        return self.tables["summary"]


def session_metrics(data: SessionData) -> SessionMetrics:
    """All the metrics of a session (see the module's functions), plus ``summary``."""
    tables = {
        "activities": activity_timeline(data),
        "goals": goals(data),
        "rules": rules_fired(data),
        "rules_by_activity": rules_by_activity(data),
        "commands": commands(data),
        "interventions": interventions(data),
        "safety": safety(data),
        "operator": operator_commands(data),
        "proximity": proximity(data),
        "robot": robot(data),
        "rejections": rejections(data),
    }
    tables["summary"] = _summary(data, tables)
    return SessionMetrics(session_id=data.session_id, tables=tables)


def _summary(data: SessionData, t: dict[str, pl.DataFrame]) -> pl.DataFrame:
    scenario = data.metadata.get("scenario", {})
    work = t["activities"].filter(~pl.col("idle"))
    outcome = t["goals"]["outcome"]
    nearest = distances(data).group_by("tick").agg(pl.col("distance_m").min())
    closest = t["proximity"].sort("min_distance_m").head(1)
    row = {
        "session_id": data.session_id,
        "scenario": scenario.get("name", ""),
        "seed": int(scenario["seed"]) if "seed" in scenario else None,
        "duration_s": (end_ms(data) + data.tick_ms) / 1000,
        "damaged": data.recovery is not None,
        "activities_started": work.height,
        "activities_completed": int((work["outcome"] == "completed").sum()),
        "activities_interrupted": int((work["outcome"] == "interrupted").sum()),
        "goals_reached": int((outcome == "reached").sum()),
        "goals_failed": int((outcome == "failed").sum()),
        "goals_interrupted": int((outcome == "interrupted").sum()),
        "rules_fired": int(t["rules"]["fired"].sum()),
        "commands": int(t["commands"]["commands"].sum()),
        "interventions": t["interventions"].height,
        "intervention_s": t["interventions"]["duration"].sum().total_seconds()
        if t["interventions"].height
        else 0.0,
        "operator_commands": t["operator"].height,
        "safety_interventions": t["safety"].height,
        "protective_stops": int(t["safety"]["stop"].sum()),
        "closest_human": closest["human"].item() if closest.height else None,
        "min_distance_m": closest["min_distance_m"].item() if closest.height else None,
        **nearest.select(*_zone_seconds(data.tick_ms)).row(0, named=True),
        **t["robot"].row(0, named=True),
        "rejected_inputs": int(t["rejections"]["count"].sum()),
    }
    return pl.DataFrame(
        [row],
        schema_overrides={
            "seed": pl.Int64,
            "min_distance_m": pl.Float64,
            "closest_human": pl.String,
        },
    )
