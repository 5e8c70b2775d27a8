"""The loop of section 4.2, ticked by hand with synthetic inputs (no world)."""

from __future__ import annotations

import itertools
import json

import msgspec
import pytest
from loop_pipeline import pipeline, pose
from oimi.pipeline.events import (
    Event,
    JoystickInput,
    MapDelta,
    ProgressKind,
    Source,
    Topic,
    encode,
)
from oimi.pipeline.loop import Pipeline, PipelineConfig
from oimi.pipeline.mapdeltas import apply_delta
from oimi.pipeline.messages import (
    InstructionBlock,
    MapUpdate,
    Move,
    MoveCommand,
    Policy,
    WorldMap,
)
from oimi.pipeline.operator.commands import Add, Command, GetReady, OperatorCommand, Start
from oimi.pipeline.sink import MemorySink


def cmd(i: int, kind: type[Command], activity: str = "") -> OperatorCommand:
    return kind(id=i, **({"activity": activity} if activity else {}))


SCRIPTED = {
    0: dict(
        commands=[
            cmd(1, Add, "example_act"),
            cmd(2, Add, "test_dance"),
            cmd(3, Start),
        ]
    ),
    1: dict(commands=[cmd(4, GetReady)]),
    3: dict(commands=[cmd(5, Start)], updates=[pose(1, 1.5, 60)]),
    40: dict(
        updates=[
            pose(2, 1.4, 800),
            MapUpdate(objectid="Nowhere/x", attributename="a", policy=Policy.R, jsonmsg="1", seq=3),
        ]
    ),
    60: dict(joystick=JoystickInput(tick=60, time_ms=1200, left_y=1.0, buttons=("LB",))),
    70: dict(joystick=JoystickInput(tick=70, time_ms=1400)),
}


def run_session(ticks: int = 1300) -> MemorySink:
    sink = MemorySink()
    p = pipeline(sink)
    for tick in range(ticks):
        p.tick(tick=tick, **SCRIPTED.get(tick, {}))
    return sink


def progress_kinds(sink: MemorySink) -> list[tuple[int, str, str]]:
    return [
        (e.tick, i.kind.value, i.activity)
        for e in sink.on(Topic.READER_PROGRESS)
        for i in e.items
        if i.kind not in (ProgressKind.BLOCK, ProgressKind.JUMP)
    ]


def test_a_two_activity_session_runs_start_to_end_in_order() -> None:
    sink = run_session()
    kinds = progress_kinds(sink)
    assert kinds[0] == (0, "idle", "idle_activity")
    loads = [(t, a) for t, k, a in kinds if k == "load"]
    assert [a for _, a in loads] == ["example_act", "test_dance"], (
        "list order: first selected runs first"
    )
    assert loads[0][0] == 3, "start at tick 3 leaves idle in the same tick"
    ends = [(a, k) for t, k, a in kinds if k == "end"]
    assert ends[:2] == [("example_act", "end"), ("test_dance", "end")]
    states = [e for e in sink.on(Topic.OPERATOR_STATE)]
    assert states[-1].button == "start"
    assert [a.state for a in states[-1].activities] == ["completed", "completed"]


def test_refused_commands_and_rejected_updates_are_logged_and_the_session_goes_on() -> None:
    sink = run_session(100)
    messages = [e.message for log in sink.on(Topic.LOG) for e in log.entries]
    assert any("start" in m.lower() for m in messages), messages  # start before get ready
    assert any("Nowhere" in m for m in messages), messages
    assert sink.on(Topic.OPERATOR_STATE)[-1].button == "stop"


def test_the_joystick_overrides_the_script_while_the_lock_is_held_and_stops_on_release() -> None:
    sink = run_session(100)
    commands = [
        (e.tick, c)
        for e in sink.on(Topic.ACTUATOR_COMMANDS)
        for c in e.commands
        if isinstance(c, MoveCommand)
    ]
    by_joystick = [t for t, c in commands if c.source == Source.JOYSTICK and c.v_x > 0]
    assert by_joystick and by_joystick[0] == 60, "the input acts in the tick it is read"
    safety = [t for t, c in commands if c.source == Source.SAFETY]
    assert safety and safety[0] == 70


def test_the_loop_stalls_until_an_update_or_the_block_moves_on() -> None:
    sink = MemorySink()
    p = pipeline(sink)
    for tick in range(10):
        p.tick(tick=tick)
    evaluated = [e.tick for e in sink.on(Topic.RULE_DECISIONS)]
    assert evaluated == [0, 1], "the idle block starts at tick 1; then nothing changes"
    behind = json.dumps({"positionrho": 1.5, "positiontheta": 3.0, "positionchangetime": 200})
    p.tick(
        tick=10,
        updates=[
            MapUpdate(
                objectid="Human/child",
                attributename="poses",
                policy=Policy.R,
                jsonmsg=behind,
                seq=1,
            )
        ],
    )
    assert sink.on(Topic.RULE_DECISIONS)[-1].tick == 10
    (child,) = sink.on(Topic.MAP)[-1].humans
    assert msgspec.json.decode(child)["positionrho"] == 1.5, "the delta holds the change"
    assert rebuilt(sink.on(Topic.MAP))[-1] == p.map
    p.tick(tick=11)
    assert sink.on(Topic.RULE_DECISIONS)[-1].tick == 10


def rebuilt(deltas: list[MapDelta]) -> list[WorldMap]:
    """The full map after each ``/map`` message."""
    maps: list[WorldMap] = []
    for delta in deltas:
        maps.append(apply_delta(maps[-1] if maps else None, delta))
    return maps


def test_the_map_is_published_only_when_it_changed() -> None:
    deltas = run_session(50).on(Topic.MAP)
    assert 0 < len(deltas) < 50
    assert [d.keyframe for d in deltas] == [True] + [False] * (len(deltas) - 1), (
        "a keyframe first, then deltas within the first 5 s"
    )
    assert all(a != b for a, b in itertools.pairwise(rebuilt(deltas)))


class HeldMaps(MemorySink):
    """Keeps, beside each ``/map`` message, the loop's own map as it was then."""

    def __init__(self) -> None:
        super().__init__()
        self.pipeline: Pipeline | None = None
        self.held: list[bytes] = []

    def record(self, topic: Topic, time_ns: int, message: Event) -> None:
        if topic is Topic.MAP and self.pipeline is not None:
            self.held.append(msgspec.json.encode(self.pipeline.map))
        super().record(topic, time_ns, message)


@pytest.mark.parametrize("keyframe_ms", [5000, 200])
def test_the_maps_rebuilt_from_map_are_the_loops_map_at_each_publish(keyframe_ms: int) -> None:
    """A whole session (1300 ticks; keyframes 5 s or 0.2 s apart): what ``/map`` records
    rebuilds, message by message, the very map the loop held when it wrote it."""
    sink = HeldMaps()
    p = sink.pipeline = pipeline(sink, PipelineConfig(map_keyframe_ms=keyframe_ms))
    for tick in range(1300):
        p.tick(tick=tick, **SCRIPTED.get(tick, {}))
    deltas = sink.on(Topic.MAP)
    assert len(sink.held) == len(deltas) > 20
    # held decoded as a WorldMap: the test's scripts put ints in float fields (Led.r=0)
    # that a map read back spells 0.0; every value must be the same
    typed = [msgspec.json.encode(msgspec.json.decode(h, type=WorldMap)) for h in sink.held]
    assert [msgspec.json.encode(m) for m in rebuilt(deltas)] == typed
    keyframes = [d.time_ms for d in deltas if d.keyframe]
    assert keyframes[0] == deltas[0].time_ms and 1 < len(keyframes) < len(deltas)
    assert all(b - a >= keyframe_ms for a, b in itertools.pairwise(keyframes))


def test_a_rule_forced_switch_takes_effect_in_the_next_tick() -> None:
    sink = MemorySink()
    p = pipeline(sink)
    p.tick(tick=0)
    info = p.map.scriptinfo
    info.currentactivity, info.goalid, info.actionid, info.blockid = (
        "wait_for_child",
        "goal0",
        "act0",
        "blk0",
    )
    info.overridecmd = True
    p.tick(tick=1)
    assert p.map.scriptinfo.currentactivity == "wait_for_child"
    assert any(
        i.kind == ProgressKind.SWITCH for e in sink.on(Topic.READER_PROGRESS) for i in e.items
    )


def test_a_block_changed_by_a_rule_restarts_in_the_actuator() -> None:
    sink = MemorySink()
    p = pipeline(sink)
    for tick in range(5):
        p.tick(tick=tick)
    p.map.scriptinfo.block = InstructionBlock(
        move=(Move(v_x=0.2, v_y=0, v_theta=0, wait_t=0, duration=100),)
    )
    p.map.scriptinfo.changed = True
    p.tick(tick=5)
    moves = [
        c
        for e in sink.on(Topic.ACTUATOR_COMMANDS)
        if e.tick == 5
        for c in e.commands
        if isinstance(c, MoveCommand)
    ]
    assert moves and moves[0].v_x == 0.2 and not p.map.scriptinfo.changed


def test_two_runs_give_identical_event_streams() -> None:
    first = [(t, ns, encode(e)) for t, ns, e in run_session(300).events]
    second = [(t, ns, encode(e)) for t, ns, e in run_session(300).events]
    assert first == second
    assert msgspec.json.decode(first[0][2])["tick"] == 0
