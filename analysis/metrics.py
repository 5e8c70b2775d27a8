"""Session metrics: polars tables computed from a loaded session (``analysis.load``).

Every function takes a :class:`~analysis.load.SessionData` and returns a frame;
:func:`session_metrics` gathers them with a one-row ``summary`` used to compare
sessions. Times are simulated milliseconds (``*_ms``) or seconds (``*_s``).

Long module: every session metric is one small polars function over the same
loaded session; split by topic they would import each other's helpers.
"""

from __future__ import annotations

import hashlib
import re
from typing import Final

import msgspec
import polars as pl
from oimi.analysis.load import TIME, SessionData
from oimi.analysis.stream import Streamed, rule_episodes_frame
from oimi.pipeline.events import REJECTING_SOURCES, Level, ProgressKind
from oimi.pipeline.proximity import ZONE_NAMES
from oimi.pipeline.think.library import BUILTIN_RULES
from oimi.recorder.metadata import ScenarioRecord

_STARTS: Final = (ProgressKind.LOAD.value, ProgressKind.IDLE.value)
_ENDS: Final = (ProgressKind.END.value, ProgressKind.SWITCH.value)
_OUTCOMES: Final = ("completed", "interrupted")
_GOALS: Final = {
    ProgressKind.GOAL_REACHED.value: "reached",
    ProgressKind.GOAL_FAILED.value: "failed",
    ProgressKind.GOAL_INTERRUPTED.value: "interrupted",
}


def end_ms(data: SessionData) -> int:
    """The last simulated time recorded (on any loaded or streamed topic)."""
    last = [t["time_ms"].max() for t in data.tables.values() if t.height]
    last.append(data.streamed.last_ms if data.streamed is not None else None)
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
        .filter(pl.col("cmd") == "add")
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


def housekeeping_codes() -> frozenset[int]:
    """Rule codes whose definition is tagged ``housekeeping`` (``pipeline.think.library``)."""
    return frozenset(cls.rulecode for cls in BUILTIN_RULES if cls.housekeeping)


def rule_episodes(data: SessionData, *, housekeeping: bool = False) -> pl.DataFrame:
    """Each firing episode of each rule (rising edge to falling edge), with the activity
    running when it began and its duration; housekeeping rules only when asked.

    The rules run after the Block Reader in a tick, so the activity running is the one of
    the reader's last progress item at or before that time (a progress message's own
    ``activity`` is the map's ``currentactivity``, which a rule forcing a switch has
    already set to the activity it switches *to*).
    """
    streamed = _streamed(data)
    place = (
        data["/reader/progress/items"]
        .select("time_ms", "activity")
        .group_by("time_ms", maintain_order=True)
        .last()
        .sort("time_ms")
    )
    chores = housekeeping_codes()
    episodes = (
        rule_episodes_frame(streamed.rules)
        .with_columns(
            housekeeping=pl.col("rulecode").is_in(list(chores)),
            still_firing=pl.col("ended_ms").is_null(),
            ended_ms=pl.col("ended_ms").fill_null(end_ms(data) + streamed.tick_ms),
        )
        .sort("started_ms")
        .join_asof(place, left_on="started_ms", right_on="time_ms", strategy="backward")
        .with_columns(duration=_ms_duration("ended_ms") - _ms_duration("started_ms"))
        .select(
            "rule",
            "activity",
            "started_ms",
            "ended_ms",
            "duration",
            "evaluations_fired",
            "still_firing",
            "housekeeping",
        )
    )
    return episodes if housekeeping else episodes.filter(~pl.col("housekeeping"))


def rules_fired(data: SessionData) -> pl.DataFrame:
    """Per rule: firing episodes, total time firing, first and last start, whether housekeeping."""
    evaluated = _streamed(data).rules.evaluated
    return (
        rule_episodes(data, housekeeping=True)
        .group_by("rule")
        .agg(
            episodes=pl.len(),
            firing=pl.col("duration").sum(),
            first_ms=pl.col("started_ms").min(),
            last_ms=pl.col("started_ms").max(),
            housekeeping=pl.col("housekeeping").first(),
        )
        .with_columns(
            evaluated=pl.col("rule").replace_strict(evaluated, default=0, return_dtype=pl.Int64)
        )
        .sort("housekeeping", "episodes", "rule", descending=[False, True, False])
    )


def rules_by_activity(data: SessionData) -> pl.DataFrame:
    """Firing episodes of each (non-housekeeping) rule while each activity ran."""
    return (
        rule_episodes(data)
        .group_by("activity", "rule")
        .agg(episodes=pl.len(), firing=pl.col("duration").sum())
        .sort("activity", "episodes", descending=[False, True])
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


def joystick_takeovers(data: SessionData) -> pl.DataFrame:
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


def operator_commands(data: SessionData) -> pl.DataFrame:
    """Every operator command with its reply (ok, reason) when one was recorded."""
    replies = (
        data["/operator/state/replies"]
        .select("id", "ok", "reason", replied_ms="time_ms")
        .unique("id", keep="first", maintain_order=True)
    )
    return (
        data["/operator/commands"]
        .select("time_ms", "id", "cmd", "activity")
        .join(replies, on="id", how="left")
        .sort("time_ms", "id")
    )


# --------------------------------------------------------------------- world


def _streamed(data: SessionData) -> Streamed:
    if data.streamed is None:
        raise ValueError("metrics need load_session(..., stream=True)")
    return data.streamed


def distances(data: SessionData) -> pl.DataFrame:
    """Per recorded world state and human: surface-to-surface distance to the robot, m (every
    state of a short session; evenly thinned to ``analysis.stream.MAX_SAMPLES`` beyond)."""
    samples = _streamed(data).samples.frame()
    return samples.filter(pl.col("id") != "robot").select(
        "time_ms",
        _ms_duration("time_ms").alias(TIME),
        pl.col("id").alias("human"),
        "kind",
        "surface_distance_m",
    )


def proximity(data: SessionData) -> pl.DataFrame:
    """Per human: closest surface distance (and when), contact episodes, time in each zone
    (each recorded state counted for the time since the one before,
    ``pipeline.proximity.ZONES_M``)."""
    streamed = _streamed(data)
    tracker = streamed.proximity
    rows = [
        {
            "human": who,
            "kind": tracker.kinds[who],
            "min_surface_distance_m": round(tracker.closest_m[who], 4),
            "min_at_ms": tracker.closest_at_ms[who],
            "contacts": sum(e.human == who for e in streamed.contacts),
            **{f"{zone}_s": ms / 1000 for zone, ms in tracker.zone_ms[who].items()},
        }
        for who in sorted(tracker.kinds)
    ]
    schema = {
        "human": pl.String,
        "kind": pl.String,
        "min_surface_distance_m": pl.Float64,
        "min_at_ms": pl.Int64,
        "contacts": pl.Int64,
        **{f"{zone}_s": pl.Float64 for zone in ZONE_NAMES},
    }
    return pl.DataFrame(rows, schema=schema) if rows else pl.DataFrame(schema=schema)


def contacts(data: SessionData) -> pl.DataFrame:
    """Every contact episode: who, when, how long, who closed the gap and how fast."""
    rows = [
        {
            "human": e.human,
            "kind": e.kind,
            "started_ms": e.start_ms,
            "duration": e.duration_ms,
            "initiator": str(e.initiator),
            "robot_speed_mps": e.robot_speed_mps,
            "person_speed_mps": e.person_speed_mps,
            "closing_speed_mps": round(e.closing_speed_mps, 4),
            "min_surface_distance_m": e.min_surface_distance_m,
        }
        for e in _streamed(data).contacts
    ]
    schema = {
        "human": pl.String,
        "kind": pl.String,
        "started_ms": pl.Int64,
        "duration": pl.Int64,
        "initiator": pl.String,
        "robot_speed_mps": pl.Float64,
        "person_speed_mps": pl.Float64,
        "closing_speed_mps": pl.Float64,
        "min_surface_distance_m": pl.Float64,
    }
    frame = pl.DataFrame(rows, schema=schema) if rows else pl.DataFrame(schema=schema)
    return frame.with_columns(_ms_duration("duration"))


def safety_interventions(data: SessionData) -> pl.DataFrame:
    """The safety supervisor's interventions (``/safety``) as episodes; none when the
    recording has no such topic."""
    frame = _streamed(data).safety.frame(end_ms(data))
    return frame.with_columns(
        duration=_ms_duration("ended_ms") - _ms_duration("started_ms")
    ).select("started_ms", "ended_ms", "duration", pl.exclude("started_ms", "ended_ms", "duration"))


def robot(data: SessionData) -> pl.DataFrame:
    """The robot: distance travelled, maximum and mean speed, contact ticks, commands clamped."""
    figures = _streamed(data).robot
    clamps = data["/actuator/commands"]["clamped"].sum()
    return pl.DataFrame(
        [
            {
                "distance_m": figures.distance_m,
                "max_speed_mps": figures.max_speed_mps,
                "mean_speed_mps": figures.speed_sum / max(figures.ticks, 1),
                "contact_ticks": figures.contact_ticks,
                "clamps": int(clamps),
            }
        ],
        schema={
            "distance_m": pl.Float64,
            "max_speed_mps": pl.Float64,
            "mean_speed_mps": pl.Float64,
            "contact_ticks": pl.Int64,
            "clamps": pl.Int64,
        },
    )


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


Verdicts = list[tuple[str, bool, str]]
"""Expectation verdicts: (name, passed, what was seen)."""


def session_metrics(data: SessionData, verdicts: Verdicts | None = None) -> SessionMetrics:
    """All the metrics of a session (see the module's functions), plus ``summary``;
    ``verdicts`` (checked by the caller, e.g. ``oimi analyse``) become ``expectations``."""
    tables = {
        "expectations": pl.DataFrame(
            verdicts or [],
            schema={"expectation": pl.String, "passed": pl.Boolean, "detail": pl.String},
            orient="row",
        ),
        "activities": activity_timeline(data),
        "goals": goals(data),
        "contacts": contacts(data),
        "proximity": proximity(data),
        "safety_interventions": safety_interventions(data),
        "joystick_takeovers": joystick_takeovers(data),
        "rule_episodes": rule_episodes(data),
        "rules": rules_fired(data),
        "rules_by_activity": rules_by_activity(data),
        "commands": commands(data),
        "operator": operator_commands(data),
        "robot": robot(data),
        "rejections": rejections(data),
    }
    tables["summary"] = _summary(data, tables)
    return SessionMetrics(session_id=data.session_id, tables=tables)


def _seconds(frame: pl.DataFrame, column: str = "duration") -> float:
    return frame[column].sum().total_seconds() if frame.height else 0.0


def _summary(data: SessionData, t: dict[str, pl.DataFrame]) -> pl.DataFrame:
    scenario = data.metadata.scenario or ScenarioRecord()
    work = t["activities"].filter(~pl.col("idle"))
    outcome = t["goals"]["outcome"]
    closest = t["proximity"].sort("min_surface_distance_m").head(1)
    touching = t["contacts"]
    seed = scenario.seed_number
    params = data.metadata.params
    verdicts = t["expectations"]["passed"]
    row = {
        "run": session_run_name(data),
        "session_id": data.session_id,
        "scenario": scenario.name or "",
        "params": params,
        **{f"param:{k}": v for k, v in sorted(data.metadata.variation.items())},
        "seed": seed,
        "duration_s": (end_ms(data) + data.tick_ms) / 1000,
        "damaged": data.recovery is not None,
        "passed": bool(verdicts.all()) if verdicts.len() else None,
        "expectations_passed": int(verdicts.sum()),
        "expectations_failed": int((~verdicts).sum()),
        "activities_started": work.height,
        "activities_completed": int((work["outcome"] == "completed").sum()),
        "activities_interrupted": int((work["outcome"] == "interrupted").sum()),
        "goals_reached": int((outcome == "reached").sum()),
        "goals_failed": int((outcome == "failed").sum()),
        "goals_interrupted": int((outcome == "interrupted").sum()),
        "contacts": touching.height,
        "robot_initiated_contacts": int((touching["initiator"] == "robot").sum()),
        "pushed_contacts": int((touching["initiator"] == "pushed").sum()),
        "max_closing_speed_mps": float(touching["closing_speed_mps"].max() or 0.0),
        "contact_s": _seconds(touching),
        "closest_human": closest["human"].item() if closest.height else None,
        "min_surface_distance_m": closest["min_surface_distance_m"].item()
        if closest.height
        else None,
        **{
            f"{zone}_s": float(t["proximity"][f"{zone}_s"].sum())
            for zone in ("intimate", "personal")
        },
        "safety_interventions": t["safety_interventions"].height,
        "protective_stops": int(t["safety_interventions"]["zones"].str.contains("stop").sum()),
        "safety_intervention_s": _seconds(t["safety_interventions"]),
        "rule_episodes": t["rule_episodes"].height,
        "joystick_takeovers": t["joystick_takeovers"].height,
        "joystick_s": _seconds(t["joystick_takeovers"]),
        "operator_commands": t["operator"].height,
        **t["robot"].drop("contact_ticks").row(0, named=True),
        "rejected_inputs": int(t["rejections"]["count"].sum()),
    }
    return pl.DataFrame(
        [row],
        schema_overrides={
            "seed": pl.Int64,
            "min_surface_distance_m": pl.Float64,
            "closest_human": pl.String,
            "passed": pl.Boolean,
        },
    )


def session_run_name(data: SessionData) -> str:
    """:func:`run_name` of a recorded session (its scenario file's stem, overrides and seed);
    a live session's is its recording id (sessions of one scenario differ by their inputs)."""
    if data.metadata.live is not None and data.metadata.oimi.recording_id:
        return data.metadata.oimi.recording_id
    scenario = data.metadata.scenario or ScenarioRecord()
    stem = (scenario.file or "").removesuffix(".toml") or scenario.name or ""
    return run_name(stem or data.session_id, data.metadata.params, scenario.seed_number)


MAX_PARAMS_CHARS: Final = 60
"""Overrides longer than this (as ``key=value,...``) are named by a hash instead."""
_TIDY: Final = re.compile(r"[A-Za-z0-9._=,+-]+")


def run_name(scenario: str, params: str, seed: int | None) -> str:
    """The one name of a run everywhere (batch files, comparison rows, report pages):
    ``STEM[-KEY=VALUE,...]-sSEED`` with the scenario file's stem and the overrides sorted by
    key; overrides too long or untidy for a file name are ``p`` and a short stable hash."""
    if params and (len(params) > MAX_PARAMS_CHARS or not _TIDY.fullmatch(params)):
        params = "p" + hashlib.sha256(params.encode()).hexdigest()[:10]
    middle = f"-{params}" if params else ""
    return f"{scenario}{middle}-s{seed if seed is not None else 0}"
