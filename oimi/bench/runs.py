"""The run cases: a recorded busy_playroom run beside the reference loop and its task floors.

Each repetition runs, in fresh processes and in turn, the case, the reference loop and
the task floor, so that all three see the same machine (ABCABC...). The task floor
records the session once, untimed, and times only re-writing its events through the
same sinks, and stepping a second copy of the real world with the same actuator
outputs and no pipeline: it shows how a run's time splits, and what no rebuild of the
pipeline can remove.
"""

from __future__ import annotations

import time
from functools import partial
from pathlib import Path
from typing import Any, Final

import msgspec

from oimi.bench.measure import (
    Case,
    bench_session,
    beside,
    in_child,
    interleaved,
    median,
    peak_memory_mb,
)
from oimi.bench.reference import reference_loop

BLOCK_TICKS: Final = 1_000
"""The task floor records this many ticks, untimed, before timing their writes."""
TICK_S: Final = 0.02
CROWD_EXTRA_CHILDREN: Final = 9
"""The cost-per-person case adds this many children to the scenario's three people."""


def _paths(folder: str, name: str, rerun: bool) -> tuple[Path, Path | None]:
    stem = Path(folder) / f"{name}-{'rerun' if rerun else 'mcap'}"
    return stem.with_suffix(".mcap"), stem.with_suffix(".rrd") if rerun else None


def message_count(mcap: Path) -> int:
    """Messages in an MCAP file, from its summary."""
    from mcap.reader import make_reader

    with mcap.open("rb") as stream:
        return make_reader(stream).get_summary().statistics.message_count


def run_case(ticks: int, folder: str, rerun: bool, extra_children: int = 0) -> dict[str, Any]:
    """In a child: one recorded run, timed from its first tick until its files are closed."""
    from oimi.scenarios.session.recording import recorded

    session = bench_session(ticks, extra_children=extra_children)
    mcap, rrd = _paths(folder, "run", rerun)
    with recorded(session, mcap=mcap, rrd=rrd):
        start = time.perf_counter()
        session.run()
    seconds = time.perf_counter() - start
    return {
        "seconds": seconds,
        "messages": message_count(mcap),
        "mcap_bytes": mcap.stat().st_size,
        "rrd_bytes": rrd.stat().st_size if rrd else 0,
        "peak_memory_mb": peak_memory_mb(),
    }


def task_floor(ticks: int, folder: str, rerun: bool) -> dict[str, Any]:
    """In a child: the run's real work minus the pipeline, timed part by part.

    The session is recorded exactly as ``run_case`` records it, except that its sinks
    are detached and fed afterwards, ``BLOCK_TICKS`` ticks at a time: the time spent in
    each sink (writes and closing the file) is the sink's floor. A second ``World`` of
    the same scenario and seed is stepped with the session's actuator outputs, and its
    state built each tick as the runner does: the world's floor. ``world_matches``
    says whether it ended where the session's world did.
    """
    from oimi.pipeline.sink import MemorySink
    from oimi.scenarios.session.recording import recorded
    from oimi.scenarios.simulation.world import World, stream_rng

    session = bench_session(ticks)
    mcap, rrd = _paths(folder, "floor", rerun)
    fanout = session.sink
    kept = len(_sinks_of(fanout))
    world = World(session.scenario, stream_rng(session.scenario.seed, "world"))
    with recorded(session, mcap=mcap, rrd=rrd):
        sinks = _sinks_of(fanout)[kept:]
        del _sinks_of(fanout)[kept:]
        memory = MemorySink()
        fanout.add(memory)
        seconds = {type(sink).__name__: 0.0 for sink in sinks} | {"World": 0.0}
        total = session.scenario.ticks
        for first in range(0, total, BLOCK_TICKS):
            block = range(first, min(first + BLOCK_TICKS, total))
            outputs = [session.outputs]
            for tick in block:
                session.step(tick)
                outputs.append(session.outputs)
            for sink in sinks:
                start = time.perf_counter()
                for event in memory.events:
                    sink.record(*event)
                seconds[type(sink).__name__] += time.perf_counter() - start
            memory.events.clear()
            start = time.perf_counter()
            for index, tick in enumerate(block):
                world.step(outputs[index], tick=tick)
                world.led, world.audio = outputs[index + 1].led, outputs[index + 1].audio
                state = world.state(tick=tick, time_ms=tick * session.tick_ms)
            seconds["World"] += time.perf_counter() - start
        for sink in sinks:
            start = time.perf_counter()
            sink.close()
            seconds[type(sink).__name__] += time.perf_counter() - start
    last = total - 1
    expected = session.world.state(tick=last, time_ms=last * session.tick_ms)
    return {
        "seconds": seconds,
        "messages": message_count(mcap),
        "mcap_bytes": mcap.stat().st_size,
        "world_matches": msgspec.json.encode(state) == msgspec.json.encode(expected),
        "peak_memory_mb": peak_memory_mb(),
    }


def _sinks_of(fanout: Any) -> list[Any]:
    sinks = getattr(fanout, "sinks", None)
    if not isinstance(sinks, list):
        raise RuntimeError("the task floor needs the session's FanOut to keep its sinks in .sinks")
    return sinks


def _in_turn(repetitions: int, *calls: tuple[Any, ...]) -> list[list[Any]]:
    """Each ``(function, *args)`` run in a fresh process once per repetition, in turn; per
    call, what it returned each time (it times itself)."""
    timings = interleaved(repetitions, *(partial(in_child, *call) for call in calls))
    return [[result for _, result in times] for times in timings]


FORMAT_1_MB_PER_MIN: Final = 0.60
"""busy_playroom's MCAP per simulated minute in recording format 1 (issue 20's baseline:
the recording is to be half of it)."""

FLOORS: Final = {
    "McapSink": "floor: its events -> MCAP sink",
    "RerunSink": "floor: its events -> Rerun sink",
    "World": "floor: its world, no pipeline",
}


def bench_run(ticks: int, repetitions: int, folder: str, *, rerun: bool) -> list[Case]:
    """The run case, its reference loop and its task floors, interleaved; medians."""
    runs, references, floors = _in_turn(
        repetitions,
        (run_case, ticks, folder, rerun),
        (reference_loop, ticks, Path(folder) / "reference.mcap"),
        (task_floor, ticks, folder, rerun),
    )
    rate = ticks / median([r["seconds"] for r in runs])
    pairs = [ref.seconds / run["seconds"] for run, ref in zip(runs, references, strict=True)]
    name = "run + MCAP + Rerun" if rerun else "run + MCAP"
    minutes = ticks * TICK_S / 60
    last = runs[-1]
    reference = references[-1]
    case = beside(
        name,
        rate,
        "ticks/s",
        "reference loop",
        ticks / median([r.seconds for r in references]),
        target=">= 5,000 ticks/s"
        if rerun
        else ">= 0.8 of the reference loop and >= 13,000 ticks/s",
        extra={
            "speed_up_x": rate * TICK_S,
            "ratio_lowest": min(pairs),  # each repetition's run over its reference loop's
            "ratio_highest": max(pairs),
            "peak_memory_mb": max(r["peak_memory_mb"] for r in runs),
            "messages_per_tick": last["messages"] / ticks,
            "mcap_mb_per_min": last["mcap_bytes"] / 1e6 / minutes,
            "rrd_mb_per_min": last["rrd_bytes"] / 1e6 / minutes,
            "reference_messages_per_tick": sum(reference.messages.values()) / ticks,
            "reference_mcap_mb_per_min": reference.file_bytes / 1e6 / minutes,
            "floor_wrote_the_runs_messages": float(
                all(f["messages"] == last["messages"] for f in floors)
            ),
            "floor_world_matched_the_runs": float(all(f["world_matches"] for f in floors)),
        },
    )
    rows = [case]
    for part, label in FLOORS.items():
        if part in floors[-1]["seconds"]:
            floor_rate = ticks / median([f["seconds"][part] for f in floors])
            rows.append(
                Case(
                    name=label,
                    value=floor_rate,
                    unit="ticks/s",
                    against=name,
                    against_value=rate,
                    ratio=rate / floor_rate,
                    target="ratio: share of the run's time",
                )
            )
    if not rerun:
        rows.append(
            Case(
                name="recording per simulated minute",
                value=case.extra["mcap_mb_per_min"],
                unit="MB/min",
                target=f"<= {FORMAT_1_MB_PER_MIN / 2:.2f}, half of format 1's"
                f" {FORMAT_1_MB_PER_MIN:.2f}",
                extra={"messages_per_tick": case.extra["messages_per_tick"]},
            )
        )
    return rows


def bench_memory(short_ticks: int, long_ticks: int, folder: str) -> Case:
    """Peak memory (VmHWM) of a long recorded run against a short one's: flat memory."""
    short = in_child(run_case, short_ticks, folder, False)["peak_memory_mb"]
    long = in_child(run_case, long_ticks, folder, False)["peak_memory_mb"]
    return Case(
        name=f"memory ({long_ticks} vs {short_ticks} ticks)",
        value=long / short,
        unit="x peak memory",
        target="<= 1.5x",
        extra={"short_mb": short, "long_mb": long},
    )


def bench_crowd(ticks: int, repetitions: int, folder: str) -> Case:
    """What each person costs: recorded runs with the scenario's 3 people and with
    ``CROWD_EXTRA_CHILDREN`` more children, interleaved; the slope per person and tick."""
    few, many = (
        [run["seconds"] for run in runs]
        for runs in _in_turn(
            repetitions,
            (run_case, ticks, folder, False),
            (run_case, ticks, folder, False, CROWD_EXTRA_CHILDREN),
        )
    )
    slope_s = (median(many) - median(few)) / ticks / CROWD_EXTRA_CHILDREN
    return Case(
        name=f"cost per person (3 vs {3 + CROWD_EXTRA_CHILDREN} people)",
        value=slope_s * 1e6,
        unit="us/tick",
        target="<= 5 us per person per tick",
        extra={
            "ticks": ticks,
            "few_ticks_per_s": ticks / median(few),
            "many_ticks_per_s": ticks / median(many),
        },
    )
