"""The process pool runs top-level functions, and runs a task again when its worker is lost."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from oimi.batch.executors import ExecutorError, ProcessPool


def square(number: int) -> int:
    return number * number


def die_once(marker: str) -> str:
    """Kills its worker the first time it sees ``marker`` missing (a lost worker)."""
    path = Path(marker)
    if not path.exists():
        path.write_text("died")
        os._exit(1)
    return path.name


def always_die(_: str) -> str:
    os._exit(1)


def test_the_pool_yields_every_result_with_its_index() -> None:
    results = dict(ProcessPool(workers=2).map(square, [1, 2, 3, 4]))
    assert results == {0: 1, 1: 4, 2: 9, 3: 16}


def test_a_task_lost_with_its_worker_runs_again(tmp_path: Path) -> None:
    items = [str(tmp_path / "a"), str(tmp_path / "b")]
    assert dict(ProcessPool(workers=1, retries=2).map(die_once, items)) == {0: "a", 1: "b"}


def test_a_pool_that_keeps_losing_workers_gives_up_with_a_clear_error() -> None:
    with pytest.raises(ExecutorError, match="lost a worker process 2 times; 1 run unfinished"):
        list(ProcessPool(workers=1, retries=1).map(always_die, ["x"]))
