"""What every case shares: the result row, timing, fresh child processes and their peak memory."""

from __future__ import annotations

import gc
import multiprocessing
import statistics
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Final

import msgspec

BENCH_SCENARIO: Final = Path(__file__).resolve().parents[2] / "scenarios/library/busy_playroom.toml"
STATUS: Final = Path("/proc/self/status")


class Case(msgspec.Struct, kw_only=True):
    """One row of the results: a median figure and what it is compared with.

    ``ratio`` is ``value / against_value`` for a case beside its reference loop, floor
    or baseline; for a floor row it is the case's figure over the floor's, the share
    of the case's time that the floor's work alone takes.
    """

    name: str
    value: float
    unit: str
    against: str = ""
    """What ``against_value`` measures: "reference loop", "floor: ...", "baseline: ..."."""
    against_value: float | None = None
    ratio: float | None = None
    target: str = ""
    extra: dict[str, float] = {}


def beside(
    name: str, value: float, unit: str, against: str, against_value: float, **fields: Any
) -> Case:
    """A case compared with another figure in the same unit (higher is faster)."""
    return Case(
        name=name,
        value=value,
        unit=unit,
        against=against,
        against_value=against_value,
        ratio=value / against_value if against_value else None,
        **fields,
    )


def median(values: list[float]) -> float:
    return statistics.median(values)


def timed(work: Callable[[], Any]) -> tuple[float, Any]:
    """Seconds ``work()`` took, and what it returned."""
    start = time.perf_counter()
    result = work()
    return time.perf_counter() - start, result


def interleaved(repetitions: int, *works: Callable[[], Any]) -> list[list[tuple[float, Any]]]:
    """Each of ``works`` timed once per repetition, in turn (ABAB...); per work, its
    ``(seconds, result)`` of every repetition. The garbage of the work before is collected
    first, untimed, so that no work pays for another's."""
    timings: list[list[tuple[float, Any]]] = [[] for _ in works]
    for _ in range(repetitions):
        for work, times in zip(works, timings, strict=True):
            gc.collect()
            times.append(timed(work))
    return timings


def per_second(count: float, timings: list[tuple[float, Any]]) -> float:
    """The median rate of ``count`` things done in each of ``timings``' seconds."""
    return median([count / seconds for seconds, _ in timings])


def in_child(function: Callable[..., Any], *args: Any) -> Any:
    """``function(*args)`` in a fresh interpreter (spawned): its memory and caches are its own."""
    context = multiprocessing.get_context("spawn")
    with context.Pool(1) as pool:
        return pool.apply(function, args)


def peak_memory_mb() -> float:
    """This process's peak resident memory (``VmHWM``), in MiB.

    Not ``ru_maxrss``: a spawned child starts by exec from a fork of its parent, and
    Linux carries the parent's high-water mark across exec into ``ru_maxrss``, so a
    child would report at least its parent's peak. ``VmHWM`` belongs to the child's
    own address space.
    """
    for line in STATUS.read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError(f"no VmHWM in {STATUS}")


def bench_session(ticks: int, *, extra_children: int = 0):
    """A session of the bench scenario stretched to ``ticks`` ticks, with ``extra_children``
    copies of its children (same behaviours, new ids, spread over the open floor)."""
    from oimi.scenarios.loader import load_scenario
    from oimi.scenarios.session.runner import Session

    loaded = load_scenario(BENCH_SCENARIO)
    scenario = loaded.scenario
    children = [h for h in scenario.humans if h.role == "child"]
    spots = [(x + 0.5, y + 0.5) for y in range(1, 5) for x in range(1, 6) if (x, y) != (3, 2)]
    if extra_children > len(spots):
        raise ValueError(f"at most {len(spots)} extra children fit, not {extra_children}")
    copies = [
        msgspec.structs.replace(children[i % len(children)], id=f"extra{i}", x_m=x, y_m=y)
        for i, (x, y) in enumerate(spots[:extra_children])
    ]
    scenario = msgspec.structs.replace(
        scenario,
        duration_s=ticks * scenario.tick_ms / 1000,
        humans=[*scenario.humans, *copies],
    )
    return Session(msgspec.structs.replace(loaded, scenario=scenario))
