"""The results as a Markdown table (printed as the suite goes) and as JSON (bench.json)."""

from __future__ import annotations

import json
import os
import platform
from pathlib import Path

import msgspec

from oimi.bench.measure import Case


def header() -> str:
    return (
        f"| {'case':<38} | {'median':>12} | {'unit':<13} | {'compared with':<38} "
        f"| {'its median':>12} | {'ratio':>5} | target |\n"
        f"|{'-' * 40}|{'-' * 13}:|{'-' * 15}|{'-' * 40}|{'-' * 13}:|{'-' * 6}:|--------|"
    )


def format_row(case: Case) -> str:
    """A table row; a floor of the run case above it is marked ``↳``."""
    name = f"↳ {case.name}" if case.name.startswith("floor:") else case.name
    against = f"{case.against_value:,.0f}" if case.against_value else "-"
    ratio = f"{case.ratio:.2f}" if case.ratio is not None else "-"
    return (
        f"| {name:<38} | {case.value:>12,.2f} | {case.unit:<13} | {case.against or '-':<38} "
        f"| {against:>12} | {ratio:>5} | {case.target} |"
    )


def write_results(
    out: Path,
    cases: list[Case],
    *,
    quick: bool,
    ticks: int,
    repetitions: int,
    compiled_modules: int,
) -> None:
    """``out`` as JSON: the settings, the machine (``compiled_modules``: how many hot modules
    ran compiled), the headline ratio (the medians', and the lowest and highest of the
    repetitions, each run beside the reference loop run after it) and every case."""
    by_name = {case.name: case for case in cases}
    run = by_name.get("run + MCAP")
    out.parent.mkdir(parents=True, exist_ok=True)
    results = {
        "quick": quick,
        "ticks": ticks,
        "repetitions": repetitions,
        "machine": {
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
            "compiled_modules": compiled_modules,
        },
        "headline": {
            "case": "run + MCAP",
            "ticks_per_s": run.value if run else None,
            "reference_loop_ticks_per_s": run.against_value if run else None,
            "ratio": run.ratio if run else None,
            "ratio_lowest": run.extra.get("ratio_lowest") if run else None,
            "ratio_highest": run.extra.get("ratio_highest") if run else None,
        },
        "cases": [msgspec.to_builtins(case) for case in cases],
    }
    out.write_text(json.dumps(results, indent=2) + "\n")
