"""Where batch tasks run: a local process pool, or Ray (a local instance or a cluster).

Both run a top-level function over a list of items and yield ``(index, result)``
as results arrive (not in order). Tasks are pure, so a task lost with its worker
is simply run again: the pool restarts and resubmits the unfinished ones (up to
``retries`` times); Ray does the same through ``max_retries``.
"""

from __future__ import annotations

import importlib
import logging
import multiprocessing
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Final, Protocol, TypeVar

from oimi.pipeline.plurals import counted
from oimi.scenarios.errors import ScenarioError

Item = TypeVar("Item")
Result = TypeVar("Result")

RAY_INSTALL_HINT: Final = (
    "--ray needs Ray: pip install 'oimi[ray]' (or pip install 'ray>=2.40' into the environment)"
)


class ExecutorError(ScenarioError):
    """An executor that cannot start or keeps losing its workers."""


class Executor(Protocol):
    """Runs ``fn`` over ``items`` somewhere; yields ``(index, result)`` as each finishes."""

    def map(
        self, fn: Callable[[Item], Result], items: Sequence[Item]
    ) -> Iterator[tuple[int, Result]]: ...

    def close(self) -> None: ...


def default_workers() -> int:
    return os.cpu_count() or 1


class ProcessPool:
    """A pool of spawned processes (``fn`` must be importable: a module's top-level function)."""

    def __init__(self, *, workers: int | None = None, retries: int = 2) -> None:
        self.workers = max(1, workers or default_workers())
        self.retries = retries
        self.context = multiprocessing.get_context("spawn")

    def map(
        self, fn: Callable[[Item], Result], items: Sequence[Item]
    ) -> Iterator[tuple[int, Result]]:
        pending = dict(enumerate(items))
        losses = 0
        while pending:
            pool = ProcessPoolExecutor(
                max_workers=min(self.workers, len(pending)), mp_context=self.context
            )
            try:
                futures: dict[Future[Result], int] = {
                    pool.submit(fn, item): index for index, item in pending.items()
                }
                waiting = set(futures)
                while waiting:
                    done, waiting = wait(waiting, return_when=FIRST_COMPLETED)
                    for future in sorted(done, key=futures.__getitem__):
                        result = future.result()
                        del pending[futures[future]]
                        yield futures[future], result
            except BrokenProcessPool as error:
                losses += 1
                if losses > self.retries:
                    raise ExecutorError(
                        f"lost a worker process {counted(losses, 'time')};"
                        f" {counted(len(pending), 'run')} unfinished",
                        source="<process pool>",
                    ) from error
            finally:
                pool.shutdown(wait=True, cancel_futures=True)

    def close(self) -> None:
        """Nothing to release: each ``map`` owns its pool."""


class RayExecutor:
    """Ray tasks on a cluster (``address``) or on a local instance started and stopped here."""

    def __init__(
        self, *, address: str | None = None, workers: int | None = None, retries: int = 3
    ) -> None:
        self.ray = import_ray()
        self.retries = retries
        options: dict[str, Any] = {
            "include_dashboard": False,
            "log_to_driver": False,
            "logging_level": logging.ERROR,
        }
        if address is None:
            options["num_cpus"] = max(1, workers or default_workers())
        else:
            options["address"] = address
        self.ray.init(**options)

    def map(
        self, fn: Callable[[Item], Result], items: Sequence[Item]
    ) -> Iterator[tuple[int, Result]]:
        ray = self.ray
        remote = ray.remote(max_retries=self.retries, num_cpus=1)(fn)
        refs = {remote.remote(item): index for index, item in enumerate(items)}
        waiting = list(refs)
        try:
            while waiting:
                done, waiting = ray.wait(waiting, num_returns=1)
                for ref in done:
                    yield refs[ref], ray.get(ref)
        finally:
            for ref in waiting:
                ray.cancel(ref)

    def close(self) -> None:
        """Disconnect (and stop the local instance, when this executor started one)."""
        self.ray.shutdown()


def import_ray() -> Any:
    """The ``ray`` module, or a clear error saying how to install it."""
    try:
        return importlib.import_module("ray")
    except ImportError:
        raise ExecutorError(RAY_INSTALL_HINT, source="--ray") from None
