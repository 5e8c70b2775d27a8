"""A Script written back as DSL text (the inverse of :func:`compile_dsl`).

Labels are generated (``g0a1b2`` for ``goal0/act1/blk2``) only for blocks that a jump
targets; names are written bare when they can be, quoted (JSON escapes) otherwise.
"""

from __future__ import annotations

import json
import re
from typing import Any, Final

from oimi.pipeline.messages import (
    CHANNELS,
    Block,
    ChannelSpec,
    InstructionBlock,
    JumpBlock,
    RuleMessage,
    Script,
    SensorBlock,
    TerminusBlock,
)
from oimi.pipeline.script.errors import ScriptError
from oimi.pipeline.script.numbers import format_number
from oimi.pipeline.script.validate import TARGET, block_path, iter_blocks

_BARE: Final = re.compile(r"[A-Za-z0-9_.\-/\\]+")
_RESERVED: Final = frozenset({"action"})
_CONDITION_STRING: Final = re.compile(r'"(?:[^"\\\n]|\\.)*"')


def render_dsl(script: Script) -> str:
    """The DSL text of ``script``; compiling it gives ``script`` back."""
    labels = {}
    for _path, block in iter_blocks(script):
        if isinstance(block, JumpBlock):
            for target in (block.truejump, block.falsejump):
                match = TARGET.fullmatch(target)
                if match:
                    labels[target] = "g{}a{}b{}".format(*match.groups())
    out = [f"[{_name(script.activityname, reserved=True)}]"]
    out += [_rule("alfa", m) for m in script.alfarulemessages]
    out += [_rule("omega", m) for m in script.omegarulemessages]
    for g, goal in enumerate(script.goals):
        out.append(f"[goal:{_name(goal.goalid)}]")
        for a, action in enumerate(goal.actions):
            out.append("[action]")
            for b, block in enumerate(action.blocks):
                path = block_path(g, a, b)
                out.append(_block(block, labels.get(path, ""), labels, path))
    return "\n".join(out) + "\n"


def _name(value: str, *, reserved: bool = False) -> str:
    if _BARE.fullmatch(value) and not (reserved and value in _RESERVED):
        return value
    return _quote(value)


def _quote(value: str) -> str:
    return json.dumps(value, ensure_ascii=False)


def _rule(kind: str, message: RuleMessage) -> str:
    fields = (
        str(message.rulecode),
        _name(message.id),
        _quote(message.intopic),
        _quote(message.outtopic),
        message.action.name,
        message.mutexcmd.name,
    )
    return f"[{kind}:{', '.join(fields)}]"


def _block(block: Block, label: str, labels: dict[str, str], path: str) -> str:
    head = f"[b#{label}#"
    match block:
        case InstructionBlock():
            lists = "".join(
                f"\n    {spec.dsl}({_list([_item(spec, x) for x in getattr(block, spec.field)])})"
                for spec in CHANNELS
            )
            flag = "" if block.flagged is None else f"\n    FLG({_quote(block.flagged)})"
            return f"{head}blk_inst:{lists}{flag}]"
        case JumpBlock():
            _check_condition(block.toparse, path)
            true = labels.get(block.truejump, "")
            false = labels.get(block.falsejump, "")
            return f"{head}blk_jump: CND({block.toparse}) TRJMP({true}) FLSJMP({false})]"
        case TerminusBlock():
            return f"{head}blk_terminus]"
        case SensorBlock():
            request = f": {_quote(block.request)}" if block.request else ""
            return f"{head}blk_sensor{request}]"
    raise ScriptError(f"{path}: not a block: {block!r}", path=path)


def _item(spec: ChannelSpec, item: Any) -> str:
    """One item of a channel as its quoted string of values (numbers at their shortest)."""
    values = (getattr(item, name) for name, _ in spec.item_fields())
    return _quote(
        ", ".join(format_number(float(v)) if isinstance(v, float) else str(v) for v in values)
    )


def _list(items: list[str]) -> str:
    if len(items) <= 1:
        return "".join(items)
    return ",\n       ".join(items)


def _check_condition(condition: str, path: str) -> None:
    """A condition is written verbatim inside CND(...): its parentheses must balance."""
    depth = 0
    for char in _CONDITION_STRING.sub("", condition):
        if char in '"[]':
            break
        depth += {"(": 1, ")": -1}.get(char, 0)
        if depth < 0:
            break
    else:
        if depth == 0:
            return
    raise ScriptError(
        f"{path}.toparse: the condition {condition!r} cannot be written in the DSL "
        "(unbalanced parentheses, an unterminated string or a bracket outside strings)",
        path=f"{path}.toparse",
    )
