"""Checks that a Script is well formed, naming each problem by its path.

Used by both the JSON loader and the DSL compiler; ``oimi check`` adds the jump
conditions through :func:`condition_errors`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterator
from typing import Any, Final

from oimi.pipeline.errors import LocatedError
from oimi.pipeline.messages import (
    CHANNELS,
    Action,
    AudioOut,
    Channel,
    Goal,
    InstructionBlock,
    JumpBlock,
    Led,
    Move,
    MutexCmd,
    RuleAction,
    RuleMessage,
    Script,
    SensorBlock,
    TerminusBlock,
)
from oimi.pipeline.script.errors import ScriptError
from oimi.pipeline.script.sourcemap import ParsedScript, SourceMap

TARGET: Final = re.compile(r"goal(\d+)/act(\d+)/blk(\d+)")
"""A jump target: ``goalX/actY/blkZ``."""

_CONTROL: Final = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")
"""Control characters other than tab, line feed and carriage return."""

BLOCK_TYPES: Final = (InstructionBlock, JumpBlock, TerminusBlock, SensorBlock)


def block_path(goal: int, action: int, block: int) -> str:
    return f"goal{goal}/act{action}/blk{block}"


def script_errors(script: Script) -> list[ScriptError]:
    """Every problem found in ``script``, in file order (paths set, no positions)."""
    return [ScriptError(f"{path}: {message}", path=path) for path, message in _problems(script)]


def validate_script(script: Script, *, source: str, sourcemap: SourceMap | None = None) -> None:
    """Raise a ScriptError for the first problem in ``script`` (placed via ``sourcemap``)."""
    errors = script_errors(script)
    if errors:
        error = errors[0]
        if sourcemap is not None:
            raise sourcemap.place(error)
        raise ScriptError(error.message, source=source, path=error.path)


def condition_errors(
    parsed: ParsedScript, compile_condition: Callable[[str], object]
) -> list[LocatedError]:
    """Compile every jump condition; errors placed at their position in the script file."""
    errors: list[LocatedError] = []
    sourcemap = parsed.sourcemap
    for path, error in jump_failures(parsed.script, compile_condition):
        where = sourcemap.text_position(f"{path}.toparse", error.column - 1)
        line, column = where or sourcemap.locate(path)
        placed = type(error)(error.message, source=sourcemap.source, line=line, column=column)
        placed.context = sourcemap.lines.context(line, column)
        errors.append(placed)
    return errors


def jump_failures(
    script: Script, compile_condition: Callable[[str], object]
) -> Iterator[tuple[str, LocatedError]]:
    """``(goalX/actY/blkZ, error)`` for each jump condition that does not compile (placed in
    the condition's text)."""
    for path, block in iter_blocks(script):
        if isinstance(block, JumpBlock):
            try:
                compile_condition(block.toparse)
            except LocatedError as error:
                yield path, error


def iter_blocks(script: Script) -> Iterator[tuple[str, object]]:
    """``(goalX/actY/blkZ, block)`` for every block, in order."""
    for g, goal in enumerate(script.goals):
        for a, action in enumerate(goal.actions):
            for b, block in enumerate(action.blocks):
                yield block_path(g, a, b), block


def target_exists(script: Script, target: str) -> bool:
    """Whether ``target`` (``goalX/actY/blkZ``) names a block of ``script``."""
    match = TARGET.fullmatch(target)
    if not match:
        return False
    g, a, b = (int(part) for part in match.groups())
    return (
        g < len(script.goals)
        and a < len(script.goals[g].actions)
        and b < len(script.goals[g].actions[a].blocks)
    )


# ------------------------------------------------------------------ the checks

Problems = Iterator[tuple[str, str]]


def _problems(script: Script) -> Problems:
    if not _is_text(script.activityname) or not script.activityname:
        yield "activityname", "activityname must be a non-empty string"
    yield from _rule_messages(script.alfarulemessages, "alfarulemessages", alfa=True)
    yield from _rule_messages(script.omegarulemessages, "omegarulemessages", alfa=False)
    if not script.goals:
        yield "activityname", "the script has no goal (at least one goal is needed)"
    for g, goal in enumerate(script.goals):
        yield from _goal(script, goal, g)


def _rule_messages(messages: tuple[RuleMessage, ...], where: str, *, alfa: bool) -> Problems:
    for i, message in enumerate(messages):
        path = f"{where}[{i}]"
        if not _is_int(message.rulecode) or message.rulecode < 0:
            yield (
                f"{path}.rulecode",
                f"rulecode must be a whole number >= 0, got {message.rulecode!r}",
            )
        if not _is_text(message.id) or not message.id:
            yield f"{path}.id", "the rule id must be a non-empty string"
        for name in ("intopic", "outtopic"):
            if not _is_text(getattr(message, name)):
                yield f"{path}.{name}", f"{name} must be a string"
        if message.action not in RuleAction.__members__.values():
            yield f"{path}.action", f"action must be one of A, R, D, B, C, got {message.action!r}"
        if message.mutexcmd not in MutexCmd.__members__.values():
            yield f"{path}.mutexcmd", f"mutexcmd must be one of L, M, U, got {message.mutexcmd!r}"
            continue
        expected = _expected_mutex(i, len(messages), alfa=alfa)
        if message.mutexcmd != expected:
            rule = (
                "alfa messages are all M except the last, which is U (L is not allowed)"
                if alfa
                else "omega messages are all M except the first, which is L (U is not allowed)"
            )
            got = MutexCmd(message.mutexcmd).name
            yield f"{path}.mutexcmd", f"mutexcmd must be {expected.name} here, got {got}: {rule}"


def _expected_mutex(index: int, count: int, *, alfa: bool) -> MutexCmd:
    if alfa:
        return MutexCmd.U if index == count - 1 else MutexCmd.M
    return MutexCmd.L if index == 0 else MutexCmd.M


def _goal(script: Script, goal: Goal, g: int) -> Problems:
    path = f"goal{g}"
    if not isinstance(goal, Goal):
        yield path, "not a goal"
        return
    if not _is_text(goal.goalid) or not goal.goalid:
        yield f"{path}.goalid", "goalid must be a non-empty string"
    if not goal.actions:
        yield path, f"{path} has no action (each goal needs at least one)"
    for a, action in enumerate(goal.actions):
        yield from _action(script, action, f"{path}/act{a}")


def _action(script: Script, action: Action, path: str) -> Problems:
    if not isinstance(action, Action):
        yield path, "not an action"
        return
    if not action.blocks:
        yield path, f"{path} has no block (each action needs at least one)"
    for b, block in enumerate(action.blocks):
        yield from _block(script, block, f"{path}/blk{b}")


def _block(script: Script, block: object, path: str) -> Problems:
    match block:
        case InstructionBlock():
            for spec in CHANNELS:
                for i, item in enumerate(getattr(block, spec.field)):
                    yield from _ITEM_CHECKS[spec.channel](item, f"{path}.{spec.field}[{i}]")
            if block.flagged is not None and not _is_text(block.flagged):
                yield f"{path}.flagged", "flagged must be a string"
        case JumpBlock():
            if not _is_text(block.toparse) or not block.toparse.strip():
                yield f"{path}.toparse", "the jump has no condition (toparse is empty)"
            elif _CONTROL.search(block.toparse):
                yield f"{path}.toparse", "the condition holds a control character"
            for name in ("truejump", "falsejump"):
                target = getattr(block, name)
                if not _is_text(target):
                    yield f"{path}.{name}", f"{name} must be a string"
                elif target and not TARGET.fullmatch(target):
                    yield (
                        f"{path}.{name}",
                        f"jump target {target!r} is not a path goalX/actY/blkZ (or empty)",
                    )
                elif target and not target_exists(script, target):
                    yield f"{path}.{name}", f"jump to {target}, which does not exist"
        case TerminusBlock():
            pass
        case SensorBlock():
            if not _is_text(block.request):
                yield f"{path}.request", "request must be a string"
        case _:
            yield path, f"unknown block type {type(block).__name__}"


def _move(move: Move, path: str) -> Problems:
    if not isinstance(move, Move):
        yield path, "not a move"
        return
    for name in ("v_x", "v_y", "v_theta"):
        yield from _finite(getattr(move, name), f"{path}.{name}", name)
    yield from _times(move, path)


def _led(led: Led, path: str) -> Problems:
    if not isinstance(led, Led):
        yield path, "not a led command"
        return
    for name in ("r", "g", "b"):
        value = getattr(led, name)
        problems = list(_finite(value, f"{path}.{name}", name))
        yield from problems
        if not problems and not 0 <= value <= 1:
            yield f"{path}.{name}", f"colour {name} must be between 0 and 1, got {value:g}"
    if not _is_int(led.turnas) or led.turnas not in (0, 1):
        yield f"{path}.turnas", f"turnas must be 0 (off) or 1 (on), got {led.turnas!r}"
    yield from _times(led, path)


def _audio(audio: AudioOut, path: str) -> Problems:
    if not isinstance(audio, AudioOut):
        yield path, "not an audio command"
        return
    if not _is_text(audio.track_path):
        yield f"{path}.track_path", "track_path must be a string"
    elif audio.track_path != audio.track_path.strip():
        yield f"{path}.track_path", f"track_path {audio.track_path!r} has surrounding spaces"
    yield from _times(audio, path)


def _times(item: Move | Led | AudioOut, path: str) -> Problems:
    for name in ("wait_t", "duration"):
        value = getattr(item, name)
        if not _is_int(value) or value < 0:
            yield (
                f"{path}.{name}",
                f"{name} must be a whole number of milliseconds >= 0, got {value!r}",
            )


def _finite(value: object, path: str, name: str) -> Problems:
    if not isinstance(value, int | float) or isinstance(value, bool) or not math.isfinite(value):
        yield path, f"{name} must be a finite number, got {value!r}"


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_text(value: object) -> bool:
    return isinstance(value, str)


_ITEM_CHECKS: Final[dict[Channel, Callable[[Any, str], Problems]]] = {
    Channel.MOVE: _move,
    Channel.LED: _led,
    Channel.AUDIO: _audio,
}
"""Each channel's item check (a new channel in ``CHANNELS`` adds its row here)."""
