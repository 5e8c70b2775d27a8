"""The pure batch task: a scenario, its overrides and a seed in; a recording and a result row out.

``run_task`` is a top-level function of an importable module, so a spawned
process or a Ray worker can run it. Its outputs depend only on the task: a
retried task (a lost worker) writes the same recording and returns the same row.
The recording is written as ``NAME.partial.mcap`` and renamed when closed, as
every recording is (a killed worker leaves that file); then the row is written
beside it as ``NAME.result.json``. A run is finished exactly
when that file exists (``finished_row``), which is what ``--resume`` checks.
"""

from __future__ import annotations

import os
import time
import traceback
from pathlib import Path

import msgspec

from oimi.batch.spec import Task
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.expectations import Verdict
from oimi.scenarios.session.recording import recorded
from oimi.scenarios.session.runner import RunResult, Session, Summary

RUN_COMPLETED = "run completed"
"""Name of the failing verdict a run that crashed gets instead of its expectations."""


class ResultRow(msgspec.Struct, frozen=True, kw_only=True):
    """One finished run: its task, what the runner reported, and where its recording is."""

    task: Task
    result: RunResult
    recording: str
    """The MCAP file's name inside the batch folder ("" when the run crashed)."""
    error: str = ""
    """The crash's traceback, when the run did not finish (then ``result`` has one failing
    ``run completed`` verdict)."""

    @property
    def ok(self) -> bool:
        return not self.error and self.result.ok


def run_task(task: Task) -> ResultRow:
    """Run one task to its end, recording it; a crash becomes a failed row, not an exception."""
    mcap = task.mcap
    try:
        session = Session(
            load_scenario(
                task.scenario,
                allow_outside=task.allow_outside_paths,
                extensions=task.extensions,
            ),
            seed=task.seed,
            overrides=dict(task.overrides),
        )
        # a retried or resumed task replaces its own unfinished recording
        with recorded(
            session,
            mcap=mcap,
            rrd=None,
            overwrite=True,
            world_every_n_ticks=task.world_every_n_ticks,
        ):
            result = session.run()
        row = ResultRow(task=task, result=result, recording=mcap.name)
    except Exception:
        mcap.unlink(missing_ok=True)
        row = crashed_row(task, traceback.format_exc())
    except BaseException:  # interrupted: leave no unfinished run's recording behind
        mcap.unlink(missing_ok=True)
        raise
    _write_atomically(task.result_file, msgspec.json.encode(row))
    return row


def timed_task(task: Task) -> tuple[ResultRow, float]:
    """``run_task`` and its wall-clock seconds, for the JUnit file only (the row and its file
    hold no wall-clock value)."""
    started = time.perf_counter()
    row = run_task(task)
    return row, time.perf_counter() - started


def crashed_row(task: Task, error: str) -> ResultRow:
    """The row of a run that did not finish."""
    summary = Summary(
        scenario=Path(task.scenario).stem,
        seed=task.seed,
        ticks=0,
        duration_s=0.0,
        activities={},
        goals_reached={},
        rules_fired={},
        min_distance_m={},
        max_speed_mps=0.0,
        contacts=0,
        rejected_inputs=0,
    )
    last_line = error.strip().splitlines()[-1] if error.strip() else "crashed"
    verdict = Verdict(name=RUN_COMPLETED, ok=False, detail=last_line)
    return ResultRow(
        task=task, result=RunResult(summary=summary, verdicts=(verdict,)), recording="", error=error
    )


def finished_row(task: Task) -> ResultRow | None:
    """The row a previous run of exactly this task left, if its recording is complete."""
    try:
        row = msgspec.json.decode(task.result_file.read_bytes(), type=ResultRow)
    except (OSError, msgspec.DecodeError):
        return None
    if row.task != task or row.error or not task.mcap.is_file():
        return None
    return row


def _write_atomically(path: Path, data: bytes) -> None:
    temporary = path.with_name(path.name + ".part")
    temporary.write_bytes(data)
    os.replace(temporary, path)
