"""The thesis's Script JSON (listing 4.1): load with positions, dump in the thesis's key order.

Layout: ``activityname``, ``alfarulemessages``, ``omegarulemessages``, then ``goal0``,
``goal1``... each ``{"goalid": ..., "act0": {"blk0": {"type": ...}, ...}}``. Loading
accepts quoted numbers (``"v_x": "10"``) as well as plain ones, and rule codes as numbers
(67) or letters ("C"). Dumping writes exactly the listing's types: speeds and colours as
quoted numbers (``"v_x": "10"``, ``"b": "0.25"``), times, ``turnas`` and codes as plain
integers, so a dump of listing 4.1 is listing 4.1.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from functools import partial
from typing import Any, Final, NoReturn

from oimi.pipeline.messages import (
    CHANNELS,
    Action,
    Block,
    ChannelSpec,
    Goal,
    InstructionBlock,
    JumpBlock,
    MutexCmd,
    RuleAction,
    RuleMessage,
    Script,
    SensorBlock,
    TerminusBlock,
)
from oimi.pipeline.script.errors import ScriptError
from oimi.pipeline.script.numbers import format_number, not_a_number, parse_float, parse_int
from oimi.pipeline.script.sourcemap import (
    LineIndex,
    ParsedScript,
    SourceMap,
    child_path,
    decode_text,
)
from oimi.pipeline.script.validate import script_errors

_NUMBERED: Final = {
    "goal": re.compile(r"goal(\d+)"),
    "act": re.compile(r"act(\d+)"),
    "blk": re.compile(r"blk(\d+)"),
}
_JSON_TYPES: Final = {
    dict: "object",
    list: "array",
    str: "str",
    int: "int",
    float: "float",
    bool: "bool",
    type(None): "null",
}


# ------------------------------------------------------------------------ public


def load_script_json(text: str | bytes, *, source: str) -> Script:
    """The Script in a JSON file's text; a ScriptError names the line, column and path."""
    return parse_script_json(text, source=source).script


def parse_script_json(text: str | bytes, *, source: str) -> ParsedScript:
    """Like :func:`load_script_json`, also returning where each part was written."""
    text = decode_text(text, source=source)
    lines = LineIndex(text)
    sourcemap = SourceMap(source, lines, json_strings=True)
    if not text.strip():
        raise ScriptError(
            "empty file: expected a JSON object with the script", source=source, line=1, column=1
        )
    try:
        json.loads(text)
    except json.JSONDecodeError as error:
        raise ScriptError(
            f"invalid JSON: {error.msg}",
            source=source,
            line=error.lineno,
            column=error.colno,
            context=lines.context(error.lineno, error.colno),
        ) from None
    except RecursionError:
        raise ScriptError("invalid JSON: nested too deeply", source=source) from None
    value, _ = _Indexer(text, sourcemap).value(0, "")
    try:
        script = _Reader().script(value)
    except ScriptError as error:
        raise sourcemap.place(error) from None
    errors = script_errors(script)
    if errors:
        raise sourcemap.place(errors[0])
    return ParsedScript(script, sourcemap)


def dump_script_json(script: Script) -> str:
    """The thesis's JSON text of ``script`` (4-space indent, keys in the thesis's order)."""
    document: dict[str, Any] = {
        "activityname": script.activityname,
        "alfarulemessages": [_rule_json(m) for m in script.alfarulemessages],
        "omegarulemessages": [_rule_json(m) for m in script.omegarulemessages],
    }
    for g, goal in enumerate(script.goals):
        goal_json: dict[str, Any] = {"goalid": goal.goalid}
        for a, action in enumerate(goal.actions):
            goal_json[f"act{a}"] = {
                f"blk{b}": _block_json(block) for b, block in enumerate(action.blocks)
            }
        document[f"goal{g}"] = goal_json
    return json.dumps(document, indent=4, ensure_ascii=False) + "\n"


# ------------------------------------------------------------------------ dumping


def _rule_json(message: RuleMessage) -> dict[str, Any]:
    return {
        "rulecode": message.rulecode,
        "id": message.id,
        "intopic": message.intopic,
        "outtopic": message.outtopic,
        "action": int(message.action),
        "mutexcmd": int(message.mutexcmd),
    }


def _item_json(spec: ChannelSpec, item: Any) -> dict[str, Any]:
    """A channel's item as the listing writes it: floats as quoted numbers, the rest as is."""
    return {
        name: format_number(getattr(item, name)) if kind is float else getattr(item, name)
        for name, kind in spec.item_fields()
    }


def _block_json(block: Block) -> dict[str, Any]:
    match block:
        case InstructionBlock():
            out: dict[str, Any] = {"type": "instruction"}
            if block.flagged is not None:
                out["flagged"] = block.flagged
            for spec in CHANNELS:
                out[spec.field] = [_item_json(spec, item) for item in getattr(block, spec.field)]
            return out
        case JumpBlock():
            return {
                "type": "jump",
                "toparse": block.toparse,
                "truejump": block.truejump,
                "falsejump": block.falsejump,
            }
        case TerminusBlock():
            return {"type": "terminus"}
        case SensorBlock():
            return {"type": "sensor", "request": block.request}
    raise TypeError(f"not a block: {block!r}")


# ------------------------------------------------------------- positions of keys


def _reject_constant(name: str) -> NoReturn:
    raise ValueError(name)


class _Indexer:
    """Walks valid JSON text, building its value and recording each key's position."""

    def __init__(self, text: str, sourcemap: SourceMap):
        self.text = text
        self.sourcemap = sourcemap
        self.lines = sourcemap.lines
        self.scalar = json.JSONDecoder(parse_constant=_reject_constant).raw_decode

    def skip(self, pos: int) -> int:
        while self.text[pos] in " \t\r\n":
            pos += 1
        return pos

    def error(self, message: str, offset: int) -> NoReturn:
        line, column = self.lines.position(offset)
        raise ScriptError(
            message,
            source=self.sourcemap.source,
            line=line,
            column=column,
            context=self.lines.context(line, column),
        )

    def value(self, pos: int, path: str) -> tuple[Any, int]:
        pos = self.skip(pos)
        char = self.text[pos]
        if char == "{":
            return self.object(pos + 1, path)
        if char == "[":
            return self.array(pos + 1, path)
        try:
            return self.scalar(self.text, pos)
        except ValueError:
            self.error("NaN and Infinity are not numbers a script may hold", pos)

    def object(self, pos: int, path: str) -> tuple[dict[str, Any], int]:
        out: dict[str, Any] = {}
        pos = self.skip(pos)
        if self.text[pos] == "}":
            return out, pos + 1
        while True:
            key_at = self.skip(pos)
            key, pos = json.decoder.scanstring(self.text, key_at + 1)
            child = child_path(path, key)
            if key in out:
                self.error(f"duplicate key {key!r}", key_at)
            pos = self.skip(self.skip(pos) + 1)  # past ':'
            self.sourcemap.add(child, self.lines.position(key_at), self.lines.position(pos + 1))
            out[key], pos = self.value(pos, child)
            pos = self.skip(pos)
            if self.text[pos] == "}":
                return out, pos + 1
            pos += 1  # ','

    def array(self, pos: int, path: str) -> tuple[list[Any], int]:
        out: list[Any] = []
        pos = self.skip(pos)
        if self.text[pos] == "]":
            return out, pos + 1
        while True:
            pos = self.skip(pos)
            child = f"{path}[{len(out)}]"
            self.sourcemap.add(child, self.lines.position(pos))
            item, pos = self.value(pos, child)
            out.append(item)
            pos = self.skip(pos)
            if self.text[pos] == "]":
                return out, pos + 1
            pos += 1


# --------------------------------------------------------- JSON values -> Script


def _type_name(value: object) -> str:
    return _JSON_TYPES.get(type(value), type(value).__name__)


def _fail(path: str, message: str) -> NoReturn:
    """A shape error; messages without msgspec's ``- at `path``` tail get the path in front."""
    if "- at " not in message and path:
        message = f"{path}: {message}"
    raise ScriptError(message, path=path)


class _Reader:
    """Converts decoded JSON into a Script; shape errors in msgspec's wording, with the path."""

    def script(self, value: Any) -> Script:
        doc = self.obj(value, "")
        goals = self.numbered(
            doc, "", "goal", fixed=("activityname", "alfarulemessages", "omegarulemessages")
        )
        if "activityname" not in doc:
            _fail("", "Object missing required field `activityname`")
        return Script(
            activityname=self.text(doc["activityname"], "activityname"),
            alfarulemessages=self.rules(doc, "alfarulemessages"),
            omegarulemessages=self.rules(doc, "omegarulemessages"),
            goals=tuple(self.goal(goal, path) for path, goal in goals),
        )

    # -- structure

    def numbered(
        self, obj: dict[str, Any], path: str, prefix: str, fixed: tuple[str, ...]
    ) -> list[tuple[str, Any]]:
        """The ``prefixN`` members of ``obj`` in order; other keys must be in ``fixed``."""
        found: dict[int, tuple[str, Any]] = {}
        where = f"`{path}`" if path else "the top level"
        for key, member in obj.items():
            match = _NUMBERED[prefix].fullmatch(key)
            if match and str(int(match.group(1))) == match.group(1):
                found[int(match.group(1))] = (child_path(path, key), member)
            elif key not in fixed:
                expected = ", ".join([*fixed, f"{prefix}N"])
                _fail(
                    child_path(path, key),
                    f"Object contains unknown field `{key}` (expected {expected}) - at {where}",
                )
        ordered = []
        for index in range(len(found)):
            if index not in found:
                missing = f"{prefix}{index}"
                later = min(n for n in found if n > index)
                _fail(
                    found[later][0],
                    f"{prefix}{later} without {missing}: "
                    f"{prefix} numbers must run 0, 1, 2... with no gap",
                )
            ordered.append(found[index])
        return ordered

    def goal(self, value: Any, path: str) -> Goal:
        obj = self.obj(value, path)
        actions = self.numbered(obj, path, "act", fixed=("goalid",))
        if "goalid" not in obj:
            _fail(path, f"Object missing required field `goalid` - at `{path}`")
        return Goal(
            goalid=self.text(obj["goalid"], f"{path}.goalid"),
            actions=tuple(self.action(action, p) for p, action in actions),
        )

    def action(self, value: Any, path: str) -> Action:
        obj = self.obj(value, path)
        blocks = self.numbered(obj, path, "blk", fixed=())
        return Action(blocks=tuple(self.block(block, p) for p, block in blocks))

    def block(self, value: Any, path: str) -> Block:
        obj = self.obj(value, path)
        if "type" not in obj:
            _fail(path, f"Object missing required field `type` - at `{path}`")
        kind = self.text(obj["type"], f"{path}.type")
        fields: dict[str, tuple[str, ...]] = {
            "instruction": ("type", "flagged", *(spec.field for spec in CHANNELS)),
            "jump": ("type", "toparse", "truejump", "falsejump"),
            "terminus": ("type",),
            "sensor": ("type", "request"),
        }
        if kind not in fields:
            _fail(
                f"{path}.type",
                f"unknown block type {kind!r} (expected instruction, jump, terminus or sensor)",
            )
        self.known(obj, path, fields[kind])
        if kind == "instruction":
            flagged = obj.get("flagged")
            channels = {
                spec.field: self.items(obj, path, spec.field, partial(self.item, spec))
                for spec in CHANNELS
            }
            return InstructionBlock(
                **channels,
                flagged=None if flagged is None else self.text(flagged, f"{path}.flagged"),
            )
        if kind == "jump":
            if "toparse" not in obj:
                _fail(path, f"Object missing required field `toparse` - at `{path}`")
            return JumpBlock(
                toparse=self.text(obj["toparse"], f"{path}.toparse"),
                truejump=self.text(obj.get("truejump", ""), f"{path}.truejump"),
                falsejump=self.text(obj.get("falsejump", ""), f"{path}.falsejump"),
            )
        if kind == "terminus":
            return TerminusBlock()
        return SensorBlock(request=self.text(obj.get("request", ""), f"{path}.request"))

    def items(
        self, obj: dict[str, Any], path: str, name: str, read: Callable[[Any, str], Any]
    ) -> tuple[Any, ...]:
        value, where = obj.get(name, []), child_path(path, name)
        if not isinstance(value, list):
            _fail(where, f"Expected `array`, got `{_type_name(value)}` - at `{where}`")
        return tuple(read(item, f"{where}[{i}]") for i, item in enumerate(value))

    def item(self, spec: ChannelSpec, value: Any, path: str) -> Any:
        """One item of ``spec``'s channel: every field of its Struct, read by its type."""
        fields = spec.item_fields()
        obj = self.fields(value, path, tuple(name for name, _ in fields))
        values: dict[str, Any] = {}
        for name, kind in fields:
            if kind is str:
                values[name] = self.text(obj[name], f"{path}.{name}")
            else:
                values[name] = (self.float if kind is float else self.int)(obj, path, name)
        return spec.item(**values)

    def rules(self, doc: dict[str, Any], name: str) -> tuple[RuleMessage, ...]:
        return self.items(doc, "", name, self.rule) if name in doc else ()

    def rule(self, value: Any, path: str) -> RuleMessage:
        names = ("rulecode", "id", "intopic", "outtopic", "action", "mutexcmd")
        obj = self.fields(value, path, names)
        return RuleMessage(
            rulecode=self.int(obj, path, "rulecode"),
            id=self.text(obj["id"], f"{path}.id"),
            intopic=self.text(obj["intopic"], f"{path}.intopic"),
            outtopic=self.text(obj["outtopic"], f"{path}.outtopic"),
            action=self.code(obj["action"], f"{path}.action", RuleAction),
            mutexcmd=self.code(obj["mutexcmd"], f"{path}.mutexcmd", MutexCmd),
        )

    # -- leaves

    def obj(self, value: Any, path: str) -> dict[str, Any]:
        if not isinstance(value, dict):
            _fail(path, f"Expected `object`, got `{_type_name(value)}` - at `{path or '$'}`")
        return value

    def known(self, obj: dict[str, Any], path: str, names: tuple[str, ...]) -> None:
        for key in obj:
            if key not in names:
                _fail(
                    child_path(path, key),
                    f"Object contains unknown field `{key}` "
                    f"(expected {', '.join(names)}) - at `{path}`",
                )

    def fields(self, value: Any, path: str, names: tuple[str, ...]) -> dict[str, Any]:
        obj = self.obj(value, path)
        self.known(obj, path, names)
        for name in names:
            if name not in obj:
                _fail(path, f"Object missing required field `{name}` - at `{path}`")
        return obj

    def text(self, value: Any, path: str) -> str:
        if not isinstance(value, str):
            _fail(path, f"Expected `str`, got `{_type_name(value)}` - at `{path}`")
        return value

    def float(self, obj: dict[str, Any], path: str, name: str) -> float:
        value, where = obj[name], f"{path}.{name}"
        if isinstance(value, int | float) and not isinstance(value, bool):
            return float(value)
        if isinstance(value, str):
            number = parse_float(value)
            if number is None:
                _fail(where, not_a_number(value))
            return number
        _fail(where, f"Expected `float`, got `{_type_name(value)}` - at `{where}`")

    def int(self, obj: dict[str, Any], path: str, name: str) -> int:
        """An int, or an integer in a string; a float is kept for validation to report."""
        value, where = obj[name], f"{path}.{name}"
        if isinstance(value, int | float) and not isinstance(value, bool):
            return value  # type: ignore[return-value]
        if isinstance(value, str):
            number = parse_int(value)
            if number is not None:
                return number
            if parse_float(value) is not None:
                _fail(where, f"{name} must be a whole number, got {value!r}")
            _fail(where, not_a_number(value))
        _fail(where, f"Expected `int`, got `{_type_name(value)}` - at `{where}`")

    def code(self, value: Any, path: str, enum: type[RuleAction] | type[MutexCmd]) -> Any:
        letters = ", ".join(f"{m.name} ({m.value})" for m in enum)
        number: int | None = None
        if isinstance(value, int) and not isinstance(value, bool):
            number = value
        elif isinstance(value, str) and len(value) == 1 and value.isalpha():
            number = ord(value)
        elif isinstance(value, str):
            number = parse_int(value)
        if number is None:
            _fail(path, f"{path.rsplit('.', 1)[-1]} must be one of {letters}, got {value!r}")
        try:
            return enum(number)
        except ValueError:
            shown = f"{number} ({chr(number)!r})" if 32 < number < 0x110000 else str(number)
            _fail(path, f"{path.rsplit('.', 1)[-1]} must be one of {letters}, got {shown}")
