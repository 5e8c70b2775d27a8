"""The batch's results table (polars; Parquet and CSV) and its short text summary.

One row per run, in task order (not finishing order), only scalar columns and
no wall-clock values, so the same batch gives the same table on any executor:

``run, scenario, file, seed, params, param:KEY..., ok, passed, failed,
expect:NAME..., ticks, duration_s, max_speed_mps, min_surface_distance_m,
min_surface_distance_m:HUMAN..., contacts, robot_initiated_contacts, pushed_contacts,
max_closing_speed_mps, rejected_inputs, safety_interventions, protective_stops,
rules_fired, goals_reached, recording, error``. ``run`` is the one name of a run
(``STEM[-KEY=VALUE,...]-sSEED``, as ``oimi analyse`` names it); ``param:`` values are
the override texts; ``expect:`` and per-human columns are null for runs whose scenario
has no such expectation or human. Distances are surface to surface and contacts are episodes
(``pipeline.proximity``); ``recording`` is relative to the batch folder.
"""

from __future__ import annotations

import shlex
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Final

import polars as pl

from oimi.batch.tasks import ResultRow
from oimi.pipeline.plurals import counted
from oimi.recorder.world_sampling import DEFAULT_WORLD_EVERY_N_TICKS

PARQUET: Final = "results.parquet"
CSV: Final = "results.csv"
REPRODUCED: Final = "reproduced"
"""The folder under ``--out`` where a failing run's reproduce command writes."""

_TYPES: Final = {bool: pl.Boolean, int: pl.Int64, float: pl.Float64, str: pl.String}


def row_columns(row: ResultRow) -> dict[str, Any]:
    """One run as flat, typed columns."""
    s = row.result.summary
    task = row.task
    verdicts = row.result.verdicts
    closest = min(s.min_surface_distance_m.values(), default=None)
    columns: dict[str, Any] = {
        "run": task.name,
        "scenario": s.scenario,
        "file": Path(task.scenario).name,
        "seed": task.seed,
        "params": ",".join(f"{k}={v}" for k, v in task.overrides),
        **{f"param:{k}": v for k, v in task.overrides},
        "ok": row.ok,
        "passed": sum(v.ok for v in verdicts),
        "failed": sum(not v.ok for v in verdicts),
        **{f"expect:{v.name}": v.ok for v in verdicts},
        "ticks": s.ticks,
        "duration_s": s.duration_s,
        "max_speed_mps": s.max_speed_mps,
        "min_surface_distance_m": closest,
        **{f"min_surface_distance_m:{h}": d for h, d in s.min_surface_distance_m.items()},
        "contacts": s.contact_episodes,
        "robot_initiated_contacts": s.robot_initiated_contacts,
        "pushed_contacts": s.pushed_contacts,
        "max_closing_speed_mps": s.max_closing_speed_mps,
        "rejected_inputs": s.rejected_inputs,
        "safety_interventions": s.safety_interventions,
        "protective_stops": s.protective_stops,
        "rules_fired": sum(s.rules_fired.values()),
        "goals_reached": len(s.goals_reached),
        "recording": row.recording,
        "error": row.error.strip().splitlines()[-1] if row.error.strip() else "",
    }
    return columns


def results_frame(rows: Sequence[ResultRow]) -> pl.DataFrame:
    """The results table; columns in the order they first appear, rows in the given order."""
    records = [row_columns(row) for row in rows]
    kinds: dict[str, type | None] = {}
    for record in records:
        for name, value in record.items():
            known = kinds.setdefault(name, None)
            if value is not None and (known is None or (known is int and type(value) is float)):
                kinds[name] = type(value)
    return pl.DataFrame(
        {name: [r.get(name) for r in records] for name in kinds},
        schema={name: _TYPES[kind or float] for name, kind in kinds.items()},
        strict=False,
    )


def write_results(frame: pl.DataFrame, out_dir: Path) -> list[Path]:
    """The table as Parquet and CSV in ``out_dir``; returns the files written."""
    out_dir.mkdir(parents=True, exist_ok=True)
    parquet, csv = out_dir / PARQUET, out_dir / CSV
    frame.write_parquet(parquet)
    frame.write_csv(csv)
    return [parquet, csv]


def reproduce_command(row: ResultRow) -> str:
    """The ``oimi run`` command that runs this one task again, with everything that decides
    its recording (extensions, world sampling), into ``OUT/reproduced/`` (the batch's own
    recording stays as it was; running the command twice replaces only its own file)."""
    task = row.task
    words = ["oimi", "run", task.scenario, "--seed", str(task.seed)]
    for key, value in task.overrides:
        words += ["--param", f"{key}={value}"]
    for extension in task.extensions:
        words += ["--extension", extension]
    if task.allow_outside_paths:
        words.append("--allow-outside-paths")
    if task.world_every_n_ticks != DEFAULT_WORLD_EVERY_N_TICKS:
        words += ["--world-every", str(task.world_every_n_ticks)]
    words += ["-o", str(Path(task.out_dir) / REPRODUCED / task.mcap.name), "--overwrite"]
    return shlex.join(words)


def summary_text(rows: Sequence[ResultRow]) -> str:
    """Pass/fail counts and, for each failing run, what failed and how to reproduce it."""
    failing = [row for row in rows if not row.ok]
    passed = len(rows) - len(failing)
    lines = [f"batch: {counted(len(rows), 'run')}, {passed} passed, {len(failing)} failed"]
    for row in failing:
        lines.append(f"FAIL {row.task.name}")
        lines += [f"  {v.name}: {v.detail}" for v in row.result.verdicts if not v.ok]
        lines.append(f"  reproduce: {reproduce_command(row)}")
    return "\n".join(lines)
