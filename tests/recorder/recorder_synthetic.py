"""Synthetic events of every topic, for the recorder's tests, and reading an ``.rrd`` back."""

from __future__ import annotations

from pathlib import Path

import msgspec
import rerun.blueprint as rrb
from oimi.pipeline.events import (
    ActivityEntry,
    ActuatorCommands,
    BodyState,
    Event,
    JoystickInput,
    Level,
    LogEntries,
    LogEntry,
    MapChange,
    MapDelta,
    MotionSource,
    OperatorCommands,
    OperatorReply,
    OperatorState,
    ProgressItem,
    ProgressKind,
    ReaderProgress,
    RuleChainState,
    RuleDecision,
    RuleDecisions,
    SafetyIntervention,
    SafetyPhase,
    SafetyZone,
    SensorUpdates,
    Source,
    Topic,
    WorldState,
)
from oimi.pipeline.messages import (
    AudioCommand,
    Human,
    InstructionBlock,
    MapUpdate,
    Move,
    MoveCommand,
    MutexCmd,
    Policy,
    RuleAction,
    RuleMessage,
)
from oimi.pipeline.operator.commands import Add
from oimi.recorder.scene import ObstacleGeometry, SceneGeometry
from rerun.chunk import RrdReader

TICK_NS = 20_000_000
SCENE = SceneGeometry(
    width_m=6.0,
    height_m=4.0,
    obstacles=(
        ObstacleGeometry(id="table", kind="table", x_m=1.0, y_m=3.0, width_m=1.2, height_m=0.6),
        ObstacleGeometry(id="pillar", kind="pillar", x_m=5.0, y_m=1.0, radius_m=0.3),
    ),
    door=((0.0, 1.55), (0.0, 2.45)),
)


def world_state(tick: int, *, humans: tuple[str, ...] = ("child1", "therapist1")) -> WorldState:
    kinds = {"child1": "child", "therapist1": "therapist"}
    return WorldState(
        tick=tick,
        time_ms=tick * 20,
        robot=BodyState(
            id="robot",
            kind="robot",
            x_m=1.0 + 0.01 * tick,
            y_m=2.0,
            theta_rad=0.1 * tick,
            vx_mps=0.5,
            radius_m=0.25,
        ),
        humans=tuple(
            BodyState(id=h, kind=kinds.get(h, "visitor"), x_m=3.0, y_m=1.0 + i, radius_m=0.2)
            for i, h in enumerate(humans)
        ),
        objects=(BodyState(id="ball", kind="ball", x_m=2.0, y_m=2.5, radius_m=0.1),),
        led=(0.0, 0.0, 1.0) if tick % 2 else (0.0, 0.0, 0.0),
        audio="hello.wav" if tick >= 2 else "",
    )


def tick_events(tick: int) -> list[tuple[Topic, Event]]:
    """One event of every topic at ``tick``, in ``Topic`` order."""
    t = {"tick": tick, "time_ms": tick * 20}
    rule = RuleMessage(
        rulecode=3,
        id="avoid",
        intopic="map",
        outtopic="map",
        action=RuleAction.A,
        mutexcmd=MutexCmd.M,
    )
    events: dict[Topic, Event] = {
        Topic.SENSOR_UPDATES: SensorUpdates(
            **t,
            updates=(
                MapUpdate(
                    objectid="Human/child1",
                    attributename="positionrho",
                    policy=Policy.R,
                    jsonmsg="1.5",
                    seq=tick,
                ),
            ),
        ),
        Topic.OPERATOR_COMMANDS: OperatorCommands(
            **t,
            commands=(Add(id=tick, activity="greet", options={"name": "Ana"}),),
        ),
        Topic.OPERATOR_STATE: OperatorState(
            **t,
            button="start",
            activities=(ActivityEntry(name="greet", state="current"),),
            replies=(OperatorReply(id=tick, ok=False, reason="busy"),),
        ),
        Topic.JOYSTICK: JoystickInput(**t, left_x=0.5, left_y=-0.25, buttons=("LB", "A")),
        Topic.MAP: MapDelta(
            **t,
            keyframe=tick == 0,
            lastupdatetime=msgspec.Raw(b"%d" % (tick * 20)),
            humans=(
                msgspec.Raw(
                    msgspec.json.encode(
                        Human(id="child1", creationtime=0, positionrho=1.0 + tick / 100)
                    )
                ),
            ),
        ),
        Topic.RULE_DECISIONS: RuleDecisions(
            **t,
            decisions=(
                RuleDecision(
                    rule="avoid",
                    rulecode=3,
                    fired=True,
                    bindings={"?h": "Human/child1"},
                    changes=(MapChange(path="scriptinfo.changed", old="false", new="true"),),
                ),
                RuleDecision(rule="greet", rulecode=4, fired=False),
            ),
        ),
        Topic.RULE_CHAIN: RuleChainState(
            **t, applied=(rule,), active=("avoid",), held=(), removed=(), locked=tick == 1
        ),
        Topic.READER_PROGRESS: ReaderProgress(
            **t,
            activity="greet",
            goalid="goal0",
            actionid="act0",
            blockid=f"blk{tick // 2}",
            items=(
                ProgressItem(
                    kind=ProgressKind.BLOCK, activity="greet", path=f"goal0/act0/blk{tick // 2}"
                ),
            ),
        ),
        Topic.ACTUATOR_COMMANDS: ActuatorCommands(
            **t,
            commands=(
                MoveCommand(source=Source.SCRIPT, v_x=0.6, clamped=True, requested=(0.9, 0.0, 0.0)),
                AudioCommand(source=Source.SCRIPT, track_path="hello.wav", stop=True),
            ),
            block=InstructionBlock(
                move=(Move(v_x=0.6, v_y=0.0, v_theta=0.0, wait_t=0, duration=1000),)
            ),
        ),
        Topic.WORLD_STATE: world_state(tick),
        Topic.LOG: LogEntries(
            **t,
            entries=(
                LogEntry(level=Level.WARNING, source="producer", message="stale update", ref="7"),
                LogEntry(level=Level.ERROR, source="operator", message="rejected"),
            ),
        ),
        Topic.SAFETY: SafetyIntervention(
            **t,
            phase=SafetyPhase.START if tick == 0 else SafetyPhase.CHANGE,
            source=MotionSource.JOYSTICK,
            zone=SafetyZone.STOP if tick % 2 else SafetyZone.SLOW,
            human="child1",
            surface_distance_m=0.3 - 0.01 * tick,
            requested=(0.5, 0.0, 0.1),
            allowed=(0.2, 0.0, 0.1),
        ),
    }
    return [(topic, events[topic]) for topic in Topic]


def session(ticks: int = 6) -> list[tuple[Topic, int, Event]]:
    """``ticks`` ticks of every topic: ``(topic, time_ns, event)``."""
    return [
        (topic, tick * TICK_NS, event)
        for tick in range(ticks)
        for topic, event in tick_events(tick)
    ]


def rows(path: Path, entity: str, *, static: bool | None = None) -> list[dict]:
    """The rows of ``entity`` in a ``.rrd`` (static ones, others, or both)."""
    found = []
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path == entity and (static is None or chunk.is_static == static):
            found += chunk.to_record_batch().to_pylist()
    return found


def views(part: rrb.Container | rrb.View) -> list[rrb.View]:
    """The views of a blueprint's container, depth first."""
    if isinstance(part, rrb.View):
        return [part]
    return [view for child in part.contents for view in views(child)]
