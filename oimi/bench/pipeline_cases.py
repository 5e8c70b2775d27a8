"""Cases inside the pipeline: compiling and evaluating rule conditions, and input latency."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Final

from oimi.bench.measure import Case, bench_session, beside, interleaved, per_second

COMPILED: Final = 200
"""Condition texts compiled per repetition (the rule library's, over and over)."""
EVALUATIONS: Final = 20_000


def bench_conditions(repetitions: int) -> list[Case]:
    """Compiling the rule library's conditions; evaluating one beside a hand-written predicate."""
    from oimi.pipeline.messages import Human, WorldMap
    from oimi.pipeline.think.conditions import compile_condition
    from oimi.pipeline.think.library import BUILTIN_RULES
    from oimi.pipeline.think.stdlib import default_registry

    texts = [cls.condition_text for cls in BUILTIN_RULES]
    rounds = COMPILED // len(texts) + 1
    condition = compile_condition("{CLASS #Human L ?child ?THIS>&positionrho OP< 0.8} ! {TRUE}")
    world = WorldMap(
        humans=[Human(id=f"h{i}", creationtime=i, positionrho=1.0 + i) for i in range(3)]
    )
    world.humans[2].positionrho = 0.5

    def by_hand() -> bool:
        return any(h.positionrho < 0.8 for h in world.humans)

    loops = range(EVALUATIONS)
    compiled = default_registry().conditions

    def compile_all() -> None:
        for _ in range(rounds):
            for text in texts:
                compiled.clear()  # compiled again, not found compiled already
                compile_condition(text)

    compiles, evaluations, predicates = interleaved(
        repetitions,
        compile_all,
        lambda: [condition.evaluate(world, now_ms=0) for _ in loops],
        lambda: [by_hand() for _ in loops],
    )
    return [
        Case(
            name="compile conditions",
            value=per_second(rounds * len(texts), compiles),
            unit="conditions/s",
        ),
        beside(
            "evaluate a condition",
            per_second(EVALUATIONS, evaluations),
            "evaluations/s",
            "floor: a hand-written predicate",
            per_second(EVALUATIONS, predicates),
        ),
    ]


def bench_latency() -> list[Case]:
    """Ticks from an input to the actuator command it causes (0: the same tick)."""
    from oimi.pipeline.events import JoystickInput, Source, Topic
    from oimi.pipeline.operator.commands import Stop
    from oimi.pipeline.sink import MemorySink

    session = bench_session(400)
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
    session.step(150, commands=[session.command(Stop())])
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
