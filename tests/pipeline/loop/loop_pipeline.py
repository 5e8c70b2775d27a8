"""A pipeline to tick by hand: a minimal idle activity, a waiting script, a child's pose."""

from __future__ import annotations

import json
from typing import Any

from oimi.pipeline.loop import Pipeline, PipelineConfig
from oimi.pipeline.messages import (
    Action,
    Block,
    Goal,
    InstructionBlock,
    JumpBlock,
    Led,
    MapUpdate,
    Policy,
    RuleAction,
    Script,
)
from oimi.pipeline.operator.generators import default_catalogue
from oimi.pipeline.operator.generators.build import alfa_messages, omega_messages
from oimi.pipeline.operator.handler import GeneratorHandler
from oimi.pipeline.sink import MemorySink
from oimi.pipeline.think.reader import ScriptEntry


def one_goal(name: str, goalid: str, *blocks: Block, **rules: Any) -> Script:
    """A script of one goal of one action of ``blocks``."""
    action = Action(blocks=blocks)
    return Script(activityname=name, goals=(Goal(goalid=goalid, actions=(action,)),), **rules)


IDLE = one_goal(
    "idle_activity",
    "rest",
    InstructionBlock(led=(Led(r=0, g=0, b=0.3, turnas=1, wait_t=0, duration=500),)),
    JumpBlock(toparse="! {TRUE}", truejump="goal0/act0/blk0"),
    alfarulemessages=alfa_messages((0, "kick_starter", RuleAction.C)),
    omegarulemessages=omega_messages((0, "kick_starter", RuleAction.R)),
)
WAIT = one_goal(
    "wait_for_child",
    "wait",
    InstructionBlock(led=(Led(r=1, g=1, b=0, turnas=1, wait_t=0, duration=200),)),
)


def _update(objectid: str, attributename: str, jsonmsg: str, seq: int) -> MapUpdate:
    return MapUpdate(
        objectid=objectid, attributename=attributename, policy=Policy.R, jsonmsg=jsonmsg, seq=seq
    )


def pose(seq: int, rho: float, t: int) -> MapUpdate:
    body = json.dumps({"positionrho": rho, "positiontheta": 0.0, "positionchangetime": t})
    return _update("Human/child", "poses", body, seq)


def camera(seq: int, *, online: bool = True) -> MapUpdate:
    """The front camera's status (the safety supervisor moves nothing until a sensor is on)."""
    return _update("Camera/front", "isonline", "s_true" if online else "s_false", seq)


def frame(seq: int, time_ms: int) -> MapUpdate:
    """The front camera's heartbeat: a frame taken at ``time_ms`` (the supervisor takes a
    camera whose frames stop for offline)."""
    return _update("Camera/front", "frametime", str(time_ms), seq)


def pipeline(sink: MemorySink, config: PipelineConfig | None = None) -> Pipeline:
    return Pipeline(
        config or PipelineConfig(),
        idle=ScriptEntry(activity="idle_activity", script=IDLE, source="idle_activity"),
        resolve=lambda name: (
            ScriptEntry(activity=name, script=WAIT, source=name)
            if name == "wait_for_child"
            else None
        ),
        handler=GeneratorHandler(default_catalogue()),
        sink=sink,
    )
