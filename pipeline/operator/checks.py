"""Structural checks the Generator Handler applies to every generated script.

The thesis's rules (section 4.4): alfa messages are all ``M`` but the last,
which is ``U``, and never ``L``; omega messages are ``L`` first, then ``M``,
and never ``U``. Besides: at least one goal, goalids present and distinct,
every action and goal non-empty, jump targets ``goalX/actY/blkZ`` that exist,
colours in [0, 1], ``turnas`` 0 or 1, and times non-negative.
"""

from __future__ import annotations

from pipeline.messages import (
    InstructionBlock,
    JumpBlock,
    MutexCmd,
    RuleMessage,
    Script,
)


def script_paths(script: Script) -> tuple[str, ...]:
    """Every block's path ``goalX/actY/blkZ``, in reading order."""
    return tuple(
        f"goal{g}/act{a}/blk{b}"
        for g, goal in enumerate(script.goals)
        for a, action in enumerate(goal.actions)
        for b, _ in enumerate(action.blocks)
    )


def _rule_problems(kind: str, msgs: tuple[RuleMessage, ...]) -> list[str]:
    out: list[str] = []
    last = len(msgs) - 1
    for i, m in enumerate(msgs):
        where = f"{kind}[{i}] ({m.id})"
        if m.rulecode < 0:
            out.append(f"{where}: rulecode {m.rulecode} is negative")
        if not m.id:
            out.append(f"{kind}[{i}]: empty rule id")
        if kind == "alfa":
            want = MutexCmd.U if i == last else MutexCmd.M
        else:
            want = MutexCmd.L if i == 0 else MutexCmd.M
        if m.mutexcmd != want:
            out.append(f"{where}: mutexcmd is {m.mutexcmd.name}, expected {want.name}")
    return out


def script_problems(script: Script) -> tuple[str, ...]:
    """What is wrong with ``script`` (empty when it is fine), each naming its place."""
    out: list[str] = []
    if not script.activityname:
        out.append("empty activityname")
    out += _rule_problems("alfa", script.alfarulemessages)
    out += _rule_problems("omega", script.omegarulemessages)
    if not script.goals:
        out.append("no goals")
    paths = set(script_paths(script))
    seen: set[str] = set()
    for g, goal in enumerate(script.goals):
        if not goal.goalid:
            out.append(f"goal{g}: empty goalid")
        elif goal.goalid in seen:
            out.append(f"goal{g}: goalid {goal.goalid!r} repeats")
        seen.add(goal.goalid)
        if not goal.actions:
            out.append(f"goal{g}: no actions")
        for a, action in enumerate(goal.actions):
            if not action.blocks:
                out.append(f"goal{g}/act{a}: no blocks")
            for b, block in enumerate(action.blocks):
                out += _block_problems(f"goal{g}/act{a}/blk{b}", block, paths)
    return tuple(out)


def _block_problems(where: str, block: object, paths: set[str]) -> list[str]:
    out: list[str] = []
    match block:
        case JumpBlock(toparse=toparse, truejump=t, falsejump=f):
            if not toparse.strip():
                out.append(f"{where}: empty jump condition")
            for name, target in (("truejump", t), ("falsejump", f)):
                if target and target not in paths:
                    out.append(f"{where}: {name} {target!r} is not a block of the script")
        case InstructionBlock(move=moves, led=leds, audioout=audio):
            for i, m in enumerate(moves):
                out += _times(f"{where}/move[{i}]", m.wait_t, m.duration)
            for i, led in enumerate(leds):
                out += _times(f"{where}/led[{i}]", led.wait_t, led.duration)
                for channel in ("r", "g", "b"):
                    value = getattr(led, channel)
                    if not 0.0 <= value <= 1.0:
                        out.append(f"{where}/led[{i}]: {channel} {value} is outside [0, 1]")
                if led.turnas not in (0, 1):
                    out.append(f"{where}/led[{i}]: turnas {led.turnas} is not 0 or 1")
            for i, au in enumerate(audio):
                out += _times(f"{where}/audioout[{i}]", au.wait_t, au.duration)
                if not au.track_path:
                    out.append(f"{where}/audioout[{i}]: empty track_path")
    return out


def _times(where: str, wait_t: int, duration: int) -> list[str]:
    out = []
    if wait_t < 0:
        out.append(f"{where}: wait_t {wait_t} is negative")
    if duration < 0:
        out.append(f"{where}: duration {duration} is negative")
    return out
