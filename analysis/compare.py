"""Comparing runs: groups of scenario × parameter values, aggregated across seeds.

A comparison table has one row per run, named by ``analysis.metrics.run_name``
(``SCENARIO[-KEY=VALUE,...]-sSEED``), with a ``param:KEY`` column per swept
parameter. :func:`group_runs` gives one row per scenario × parameter values with
each metric's mean, spread (standard deviation), min and max across seeds, and the
pass rate.
"""

from __future__ import annotations

from typing import Final

import polars as pl

PARAM_PREFIX: Final = "param:"

AGGREGATED: Final = (
    "contacts",
    "robot_initiated_contacts",
    "max_closing_speed_mps",
    "min_surface_distance_m",
    "intimate_s",
    "safety_interventions",
    "goals_reached",
    "rule_episodes",
    "distance_m",
    "max_speed_mps",
    "duration_s",
)
"""The metrics aggregated per group (and plotted against each swept parameter)."""


def parameter_columns(comparison: pl.DataFrame) -> list[str]:
    return [c for c in comparison.columns if c.startswith(PARAM_PREFIX)]


def swept_parameters(comparison: pl.DataFrame) -> list[str]:
    """The ``param:`` columns that take more than one value within some scenario."""
    swept = []
    for column in parameter_columns(comparison):
        counts = comparison.group_by("scenario").agg(pl.col(column).drop_nulls().n_unique())
        if counts[column].max() > 1:  # type: ignore[operator]
            swept.append(column)
    return swept


def group_runs(comparison: pl.DataFrame) -> pl.DataFrame:
    """One row per scenario × parameter values: runs, pass rate, and per metric its
    ``mean``, ``spread`` (standard deviation over seeds), ``min`` and ``max``."""
    keys = ["scenario", "params", *parameter_columns(comparison)]
    metrics = [m for m in AGGREGATED if m in comparison.columns]
    passed = (
        [(pl.col("passed").cast(pl.Float64).mean() * 100).alias("pass rate")]
        if "passed" in comparison.columns
        else []
    )
    figures = []
    for metric in metrics:
        column = pl.col(metric).cast(pl.Float64)
        figures += [
            column.mean().alias(f"{metric} mean"),
            column.std().fill_null(0.0).alias(f"{metric} spread"),
            column.min().alias(f"{metric} min"),
            column.max().alias(f"{metric} max"),
        ]
    return (
        comparison.group_by(keys, maintain_order=True)
        .agg(pl.len().alias("runs"), pl.col("seed").sort().alias("seeds"), *passed, *figures)
        .with_columns(pl.col("seeds").cast(pl.List(pl.String)).list.join(", "))
        .sort(keys, nulls_last=True)
    )
