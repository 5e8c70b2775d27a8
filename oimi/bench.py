"""The performance suite: each case timed against its *floor*, measured in the same run.

A floor is a loop doing only the unavoidable work with the same libraries (pymunk
steps and MCAP writes for a run; reading and decoding for a replay; decompressing
and ``polars.read_ndjson`` for analysis). Figures are medians of repetitions, and
ratios to the floor, since absolute times on a shared machine mean little.
Each run case executes in a fresh process so that its peak memory is its own.
"""

from __future__ import annotations

import json
import multiprocessing
import resource
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Final

import msgspec

BENCH_SCENARIO: Final = Path(__file__).resolve().parents[1] / "scenarios/library/busy_playroom.toml"
FULL_TICKS: Final = 180_000
"""One hour at 50 Hz."""
QUICK_TICKS: Final = 1_000
MEMORY_SHORT_TICKS: Final = 3_000
"""One minute at 50 Hz: the reference of the flat-memory check."""


class Case(msgspec.Struct, kw_only=True):
    """One measured case: the median figure, its unit, and its ratio to the floor."""

    name: str
    value: float
    unit: str
    floor: float | None = None
    """The floor's figure in the same unit (higher is faster), when the case has one."""
    target: str = ""
    extra: dict[str, float] = {}

    @property
    def ratio(self) -> float | None:
        return self.value / self.floor if self.floor else None


def _median(values: list[float]) -> float:
    return statistics.median(values)


def _timed(work: Callable[[], Any]) -> tuple[float, Any]:
    start = time.perf_counter()
    result = work()
    return time.perf_counter() - start, result


# ----------------------------------------------------------------------- run cases


def _session(ticks: int):
    from scenarios.loader import load_scenario
    from scenarios.runner import Session

    loaded = load_scenario(BENCH_SCENARIO)
    scenario = msgspec.structs.replace(
        loaded.scenario, duration_s=ticks * loaded.scenario.tick_ms / 1000
    )
    return Session(msgspec.structs.replace(loaded, scenario=scenario))


def _run_case(ticks: int, folder: str, rerun: bool) -> dict[str, float]:
    """In a child process: one recorded run; returns its figures and the process's peak RSS."""
    from scenarios.recording import recorded

    session = _session(ticks)
    mcap = Path(folder) / "bench.mcap"
    rrd = Path(folder) / "bench.rrd" if rerun else None
    with recorded(session, mcap=mcap, rrd=rrd):
        seconds, _ = _timed(session.run)
    from recorder.reader import open_recording

    recording = open_recording(mcap)
    messages = sum(recording.summary.values())
    return {
        "seconds": seconds,
        "ticks": ticks,
        "messages": messages,
        "bytes": mcap.stat().st_size,
        "payload_bytes": _payload_bytes(mcap),
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "bodies": len(session.world.space.bodies),
    }


def _payload_bytes(path: Path) -> int:
    from mcap.reader import make_reader

    with path.open("rb") as stream:
        return sum(len(m.data) for _, _, m in make_reader(stream).iter_messages())


def _run_floor(ticks: int, bodies: int, messages: int, payload_bytes: int, folder: str) -> float:
    """Seconds for the same pymunk steps and the same MCAP writes of msgspec-encoded payloads."""
    import pymunk
    from mcap.writer import CompressionType, Writer

    class Payload(msgspec.Struct):
        tick: int
        text: str

    space = pymunk.Space()
    space.threads = 1
    for index in range(max(bodies, 1)):
        body = pymunk.Body(1.0, 1.0)
        body.position = (index * 0.7 % 6, index * 0.3 % 5)
        space.add(body, pymunk.Circle(body, 0.2))
    per_tick = max(messages // ticks, 1)
    text = "x" * max(payload_bytes // max(messages, 1) - 20, 1)
    start = time.perf_counter()
    with open(Path(folder) / "floor.mcap", "wb") as stream:
        writer = Writer(stream, compression=CompressionType.ZSTD, chunk_size=1024 * 1024)
        writer.start(profile="", library="floor")
        schema = writer.register_schema(name="p", encoding="jsonschema", data=b"{}")
        channel = writer.register_channel(topic="/p", message_encoding="json", schema_id=schema)
        encode = msgspec.json.Encoder().encode
        for tick in range(ticks):
            space.step(0.02)
            for _ in range(per_tick):
                writer.add_message(
                    channel,
                    log_time=tick,
                    publish_time=tick,
                    data=encode(Payload(tick=tick, text=text)),
                )
        writer.finish()
    return time.perf_counter() - start


def _in_child(function: Callable[..., Any], *args: Any) -> Any:
    context = multiprocessing.get_context("spawn")
    with context.Pool(1) as pool:
        return pool.apply(function, args)


def bench_run(ticks: int, repetitions: int, *, rerun: bool) -> tuple[Case, dict[str, float]]:
    runs, floors = [], []
    with tempfile.TemporaryDirectory() as folder:
        for _ in range(repetitions):
            figures = _in_child(_run_case, ticks, folder, rerun)
            runs.append(figures)
            floors.append(
                _run_floor(
                    ticks,
                    int(figures["bodies"]),
                    int(figures["messages"]),
                    int(figures["payload_bytes"]),
                    folder,
                )
            )
    seconds = _median([r["seconds"] for r in runs])
    floor_seconds = _median(floors)
    last = runs[-1]
    case = Case(
        name="run + MCAP + Rerun" if rerun else "run + MCAP",
        value=ticks / seconds,
        unit="ticks/s",
        floor=ticks / floor_seconds,
        target=">= 3,000 ticks/s" if rerun else ">= 10,000 ticks/s and >= 0.6 of floor",
        extra={
            "speed_up_x": ticks / seconds * 0.02,
            "peak_rss_mb": max(r["peak_rss_mb"] for r in runs),
            "mcap_mb": last["bytes"] / 1e6,
            "messages": last["messages"],
        },
    )
    return case, last


def bench_memory(ticks: int) -> Case:
    """Peak RSS of a session of ``ticks`` against a one-minute session's (flat memory)."""
    with tempfile.TemporaryDirectory() as folder:
        short = _in_child(_run_case, MEMORY_SHORT_TICKS, folder, False)["peak_rss_mb"]
        long = _in_child(_run_case, ticks, folder, False)["peak_rss_mb"]
    return Case(
        name=f"memory ({ticks} vs {MEMORY_SHORT_TICKS} ticks)",
        value=long / short,
        unit="x peak RSS",
        target="<= 1.5x",
        extra={"short_mb": short, "long_mb": long},
    )


# ----------------------------------------------------------------- language cases


def bench_conditions(repetitions: int) -> list[Case]:
    from pipeline.messages import Human, WorldMap
    from pipeline.think.conditions import compile_condition
    from pipeline.think.library import BUILTIN_RULES

    texts = [cls.condition_text for cls in BUILTIN_RULES]
    count = 200
    compile_rates = []
    for _ in range(repetitions):
        seconds, _ = _timed(
            lambda: [compile_condition(t) for _ in range(count // len(texts) + 1) for t in texts]
        )
        compile_rates.append((count // len(texts) + 1) * len(texts) / seconds)
    condition = compile_condition("{CLASS #Human L ?child ?THIS>&positionrho OP< 0.8} ! {TRUE}")
    world = WorldMap(
        humans=[Human(id=f"h{i}", creationtime=i, positionrho=1.0 + i) for i in range(3)]
    )
    world.humans[2].positionrho = 0.5

    def by_hand() -> bool:
        return any(h.positionrho < 0.8 for h in world.humans)

    loops = 20_000
    evaluations, predicates = [], []
    for _ in range(repetitions):
        seconds, _ = _timed(lambda: [condition.evaluate(world, now_ms=0) for _ in range(loops)])
        evaluations.append(loops / seconds)
        seconds, _ = _timed(lambda: [by_hand() for _ in range(loops)])
        predicates.append(loops / seconds)
    return [
        Case(name="compile conditions", value=_median(compile_rates), unit="conditions/s"),
        Case(
            name="evaluate a condition",
            value=_median(evaluations),
            unit="evaluations/s",
            floor=_median(predicates),
            target="vs a hand-written predicate",
        ),
    ]


# ------------------------------------------------------------------------ latency


def bench_latency() -> list[Case]:
    """Ticks from an input to the actuator command it causes (0: the same tick)."""
    from pipeline.events import JoystickInput, OperatorVerb, Source, Topic
    from pipeline.sink import MemorySink

    session = _session(400)
    sink = MemorySink()
    session.sink.add(sink)
    for tick in range(100):
        session.step(tick)
    session.step(100, joystick=JoystickInput(tick=100, time_ms=2000, left_y=1.0, buttons=("LB",)))
    for tick in range(101, 120):
        session.step(tick)
    session.step(120, joystick=JoystickInput(tick=120, time_ms=2400))
    for tick in range(121, 150):
        session.step(tick)
    session.step(150, commands=[session.command(OperatorVerb.STOP)])
    for tick in range(151, 200):
        session.step(tick)

    def first(predicate: Callable[[Any], bool], since: int) -> int:
        for event in sink.on(Topic.ACTUATOR_COMMANDS):
            if event.tick >= since and any(predicate(c) for c in event.commands):
                return event.tick - since
        return -1

    joystick = first(lambda c: c.source == Source.JOYSTICK, 100)
    stop = first(lambda c: c.source == Source.SCRIPT, 150)
    return [
        Case(
            name="latency joystick -> command", value=joystick, unit="ticks", target="0 (same tick)"
        ),
        Case(name="latency operator stop -> command", value=stop, unit="ticks", target="<= 1"),
    ]


# ------------------------------------------------------------ replay and analysis


def bench_replay(recording: Path, repetitions: int, run_seconds_per_tick: float) -> list[Case]:
    from recorder.reader import open_recording
    from replay.redrive import redrive

    rates, floors = [], []
    ticks = 0
    for _ in range(repetitions):
        seconds, report = _timed(lambda: redrive(recording))
        ticks = report.ticks
        rates.append(ticks / seconds)

        def decode_all() -> int:
            return sum(1 for m in open_recording(recording).iter_messages() if m.decoded())

        decode_seconds, _ = _timed(decode_all)
        floors.append(ticks / decode_seconds)
    run_rate = 1 / run_seconds_per_tick
    return [
        Case(
            name="replay redrive",
            value=_median(rates),
            unit="ticks/s",
            floor=_median(floors),
            target=f">= 2x the run ({2 * run_rate:,.0f} ticks/s)",
            extra={"run_ticks_per_s": run_rate, "vs_run": _median(rates) / run_rate},
        )
    ]


def bench_analyse(recording: Path, repetitions: int) -> list[Case]:
    from io import BytesIO

    import polars as pl
    from mcap.reader import make_reader

    from analysis.load import load_session, topic_schema
    from pipeline.events import Topic

    rates, floors = [], []
    for _ in range(repetitions):
        seconds, data = _timed(lambda: load_session(recording))
        rates.append(data.rows / seconds)

        def floor() -> None:
            payloads: dict[str, list[bytes]] = {}
            with recording.open("rb") as stream:
                for _, channel, message in make_reader(stream).iter_messages():
                    payloads.setdefault(channel.topic, []).append(message.data)
            for topic, items in payloads.items():
                if topic in Topic.__members__.values():
                    schema = topic_schema(Topic(topic))
                    pl.read_ndjson(BytesIO(b"\n".join(items)), schema=schema)

        seconds, _ = _timed(floor)
        floors.append(data.rows / seconds)
    return [
        Case(
            name="analyse (load into polars)",
            value=_median(rates),
            unit="rows/s",
            floor=_median(floors),
            target=">= 300,000 rows/s",
        )
    ]


# ------------------------------------------------------------------------- suite


def run_suite(
    *, quick: bool, repetitions: int, out: Path, echo: Callable[[str], None]
) -> list[Case]:
    """Measure every case, print a table as it goes, and write ``out`` (bench.json)."""
    ticks = QUICK_TICKS if quick else FULL_TICKS
    cases: list[Case] = []

    def add(new: list[Case]) -> None:
        for case in new:
            cases.append(case)
            echo(format_row(case))

    echo(header())
    run, figures = bench_run(ticks, repetitions, rerun=False)
    add([run])
    add([bench_run(ticks, repetitions, rerun=True)[0]])
    with tempfile.TemporaryDirectory() as folder:
        from scenarios.recording import recorded

        recording = Path(folder) / "replay.mcap"
        session = _session(ticks)
        with recorded(session, mcap=recording, rrd=None):
            session.run()
        add(bench_replay(recording, repetitions, figures["seconds"] / ticks))
        add(bench_analyse(recording, repetitions))
    add(bench_conditions(repetitions))
    add(bench_latency())
    add([bench_memory(ticks if not quick else MEMORY_SHORT_TICKS * 2)])
    out.write_text(
        json.dumps(
            {
                "quick": quick,
                "ticks": ticks,
                "repetitions": repetitions,
                "cases": [msgspec.to_builtins(c) | {"ratio": c.ratio} for c in cases],
            },
            indent=2,
        )
        + "\n"
    )
    return cases


def header() -> str:
    return (
        f"| {'case':<34} | {'median':>14} | {'unit':<14} | {'floor':>14} | {'ratio':>6} "
        "| target |\n"
        f"|{'-' * 36}|{'-' * 16}:|{'-' * 16}|{'-' * 15}:|{'-' * 7}:|--------|"
    )


def format_row(case: Case) -> str:
    floor = f"{case.floor:,.0f}" if case.floor else "-"
    ratio = f"{case.ratio:.2f}" if case.ratio else "-"
    return (
        f"| {case.name:<34} | {case.value:>14,.2f} | {case.unit:<14} | {floor:>14} | "
        f"{ratio:>6} | {case.target} |"
    )
