"""The thesis's Script DSL (section 4.4) compiled to a Script, with located errors.

The grammar (``dsl.lark``) fixes the shape of each ``[bracketed item]``; this module
turns the parse tree into typed items, checks their order, numbers and labels, and
builds the Script. Every error names its line and column (see ``docs/script-language.md``).

Long module: one lark Transformer plus its checks: each ``[bracketed item]`` is a
method of the same class, and the located-error helpers they share sit beside them.
"""

from __future__ import annotations

import functools
import json
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Final, NoReturn

from lark import Lark, Token, Transformer, UnexpectedInput
from lark.exceptions import VisitError
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
from oimi.pipeline.script.numbers import not_a_number, parse_float, parse_int
from oimi.pipeline.script.sourcemap import LineIndex, ParsedScript, Position, SourceMap, decode_text
from oimi.pipeline.script.validate import block_path, script_errors
from oimi.pipeline.texts import did_you_mean

RULE_FIELDS: Final = ("rulecode", "id", "intopic", "outtopic", "action", "mutexcmd")


MAX_NESTING: Final = 64
"""Deepest nesting of parentheses inside ``CND(...)``. The condition language itself
nests one call deep; the limit keeps the parse linear (lark's tree builder copies a
nested group's tokens once per level)."""


class _NestingLimit:
    """A post-lexer refusing a condition nested deeper than ``MAX_NESTING``, before the
    parser builds it (its ``LPAR``/``RPAR`` occur only inside ``CND(...)``)."""

    always_accept: tuple[str, ...] = ()

    def process(self, stream: Iterator[Token]) -> Iterator[Token]:
        depth = 0
        for token in stream:
            if token.type == "LPAR":
                depth += 1
                if depth > MAX_NESTING:
                    raise _TooDeep(token)
            elif token.type == "RPAR" and depth:
                depth -= 1
            yield token


class _TooDeep(Exception):
    def __init__(self, token: Token) -> None:
        super().__init__(token)
        self.token = token


def channel_grammar() -> str:
    """The grammar of an instruction block's channels, one item list per row of the channel
    registry, in its order (``dsl.lark`` names ``_channels``)."""
    rules = [f"_channels: {' '.join(f'channel_{s.dsl.lower()}' for s in CHANNELS)}"]
    for spec in CHANNELS:
        rules.append(f"channel_{spec.dsl.lower()}: {spec.dsl}_OPEN _strings? RPAR")
        rules.append(f"{spec.dsl}_OPEN.3: /{spec.dsl}[ \\t]*\\(/")
    return "\n".join(rules) + "\n"


@functools.cache
def _parser() -> Lark:
    grammar = Path(__file__).with_name("dsl.lark").read_text(encoding="utf-8")
    return Lark(
        grammar + channel_grammar(),
        parser="lalr",
        lexer="contextual",
        maybe_placeholders=False,
        postlex=_NestingLimit(),
    )


# ------------------------------------------------------------------------- public


def compile_dsl(text: str, *, source: str) -> Script:
    """The Script written in DSL ``text``; a ScriptError names the line and column."""
    return parse_dsl(text, source=source).script


def parse_dsl(text: str | bytes, *, source: str) -> ParsedScript:
    """Like :func:`compile_dsl`, also returning where each part was written."""
    text = decode_text(text, source=source)
    lines = LineIndex(text)
    try:
        tree = _parser().parse(text)
    except UnexpectedInput as error:
        raise _syntax_error(error, text, source, lines) from None
    except _TooDeep as error:
        line, column = _pos(error.token)
        raise ScriptError(
            f"parentheses in CND(...) nest deeper than {MAX_NESTING} levels",
            source=source,
            line=line,
            column=column,
            context=lines.context(line, column),
        ) from None
    try:
        items = _Items(source, lines).transform(tree).children
    except VisitError as error:
        if isinstance(error.orig_exc, ScriptError):
            raise error.orig_exc from None
        raise
    sourcemap = SourceMap(source, lines)
    script = _Builder(source, lines, sourcemap).build(items)
    errors = script_errors(script)
    if errors:
        raise sourcemap.place(errors[0])
    return ParsedScript(script, sourcemap)


# ------------------------------------------------------------------ typed items


def _pos(token: Token) -> Position:
    return (token.line or 1, token.column or 1)


@dataclass(frozen=True)
class Text:
    """A name, field or string as written, decoded, with the position of its first char."""

    value: str
    at: Position
    quoted: bool = False


@dataclass(frozen=True)
class NameItem:
    name: Text
    at: Position


@dataclass(frozen=True)
class RuleItem:
    omega: bool
    fields: list[Text | None]
    at: Position


@dataclass(frozen=True)
class GoalItem:
    goalid: Text | None
    at: Position


@dataclass(frozen=True)
class ActionItem:
    at: Position


@dataclass(frozen=True)
class InstBody:
    channels: list[list[Token]]
    """Each channel's item strings, in ``CHANNELS`` order."""
    flag: Text | None


@dataclass(frozen=True)
class JumpBody:
    condition: str
    condition_at: Position
    keyword_at: Position
    truejump: Text | None
    falsejump: Text | None
    true_at: Position
    false_at: Position


@dataclass(frozen=True)
class SensorBody:
    request: str


@dataclass(frozen=True)
class BlockItem:
    label: Text | None
    body: InstBody | JumpBody | SensorBody | None
    at: Position


class _Items(Transformer):
    """Parse tree -> typed items (strings decoded, positions kept)."""

    def __init__(self, source: str, lines: LineIndex):
        super().__init__()
        self.source = source
        self.lines = lines

    def string(self, token: Token) -> Text:
        try:
            value = json.loads(token.value, strict=False)
        except json.JSONDecodeError as error:
            line, column = token.line or 1, (token.column or 1) + error.pos
            raise ScriptError(
                f"bad escape in string {token.value}: {error.msg} (strings use JSON escapes)",
                source=self.source,
                line=line,
                column=column,
                context=self.lines.context(line, column),
            ) from None
        return Text(value, _pos(token), quoted=True)

    def text(self, token: Token) -> Text:
        if token.type == "STRING":
            return self.string(token)
        return Text(token.value.strip(), _pos(token))

    def activity(self, children: list[Token]) -> NameItem:
        return NameItem(self.text(children[1]), _pos(children[0]))

    def field(self, children: list[Token]) -> Text | None:
        return self.text(children[0]) if children else None

    def fields(self, children: list[Text | None]) -> list[Text | None]:
        return children

    def alfa(self, children: list) -> RuleItem:
        return RuleItem(False, children[2], _pos(children[0]))

    def omega(self, children: list) -> RuleItem:
        return RuleItem(True, children[2], _pos(children[0]))

    def goal(self, children: list[Token]) -> GoalItem:
        goalid = self.text(children[2]) if len(children) == 4 else None
        return GoalItem(goalid, _pos(children[0]))

    def action(self, children: list[Token]) -> ActionItem:
        return ActionItem(_pos(children[0]))

    def block(self, children: list) -> BlockItem:
        label = self.text(children[2]) if children[2].type == "NAME" else None
        return BlockItem(label, children[-2], _pos(children[0]))

    def inst(self, children: list) -> InstBody:
        parts = [c for c in children if not isinstance(c, Token)]
        count = len(CHANNELS)
        return InstBody(parts[:count], parts[count] if len(parts) > count else None)

    def __default__(self, data: str, children: list, meta: object) -> object:
        if data.startswith("channel_"):  # one channel's item strings (channel_grammar)
            return [c for c in children if c.type == "STRING"]
        return super().__default__(data, children, meta)

    def flag(self, children: list[Token]) -> Text:
        return self.string(children[1])

    def terminus(self, children: list[Token]) -> None:
        return None

    def cnd(self, children: list[Token]) -> tuple[str, Position]:
        opening, closing = children[0], children[-1]
        text = self.lines.text[opening.end_pos : closing.start_pos]
        return text, (opening.end_line or 1, opening.end_column or 1)

    def jump(self, children: list) -> JumpBody:
        keyword = children[0]
        index = 1 if isinstance(children[1], tuple) else 2
        condition, condition_at = children[index]
        rest = children[index + 1 :]
        true_open, rest = rest[0], rest[1:]
        truejump = None
        if rest[0].type == "NAME":
            truejump, rest = self.text(rest[0]), rest[1:]
        false_open = rest[1]
        falsejump = self.text(rest[2]) if rest[2].type == "NAME" else None
        return JumpBody(
            condition,
            condition_at,
            _pos(keyword),
            truejump,
            falsejump,
            _pos(true_open),
            _pos(false_open),
        )

    def sensor(self, children: list[Token]) -> SensorBody:
        if len(children) < 3:
            return SensorBody("")
        return SensorBody(self.text(children[2]).value)


# ---------------------------------------------------------------- the builder


@dataclass
class _GoalDraft:
    goalid: str
    actions: list[list[Block]] = field(default_factory=list)


@dataclass
class _PendingJump:
    path: str
    condition: str
    truejump: Text | None
    falsejump: Text | None


class _Builder:
    """Checks the items' order, numbers and labels and assembles the Script."""

    def __init__(self, source: str, lines: LineIndex, sourcemap: SourceMap):
        self.source = source
        self.lines = lines
        self.map = sourcemap

    def error(self, message: str, at: Position) -> NoReturn:
        line, column = at
        raise ScriptError(
            message,
            source=self.source,
            line=line,
            column=column,
            context=self.lines.context(line, column),
        )

    def build(self, items: list) -> Script:
        if not items:
            self.error("empty script: expected its name first, e.g. [my_activity]", (1, 1))
        first = items[0]
        if not isinstance(first, NameItem):
            self.error(
                "missing [activityname]: a script starts with its name, e.g. [my_activity]",
                first.at,
            )
        self.map.add("activityname", first.name.at)
        alfa: list[RuleMessage] = []
        omega: list[RuleMessage] = []
        goals: list[_GoalDraft] = []
        labels: dict[str, tuple[str, Position]] = {}
        jumps: list[_PendingJump] = []
        for item in items[1:]:
            match item:
                case NameItem():
                    self.second_name(item)
                case RuleItem():
                    kind = "omega" if item.omega else "alfa"
                    if goals:
                        self.error(f"[{kind}:...] after a goal: rule messages come first", item.at)
                    if not item.omega and omega:
                        self.error(
                            "[alfa:...] after [omega:...]: alfa messages come first", item.at
                        )
                    target = omega if item.omega else alfa
                    where = f"{kind}rulemessages[{len(target)}]"
                    target.append(self.rule(item, where))
                case GoalItem():
                    path = f"goal{len(goals)}"
                    self.map.add(path, item.at)
                    if item.goalid is not None:
                        self.map.add(f"{path}.goalid", item.goalid.at)
                    goals.append(_GoalDraft(item.goalid.value if item.goalid else ""))
                case ActionItem():
                    if not goals:
                        self.error("[action] before any [goal:...]", item.at)
                    path = f"goal{len(goals) - 1}/act{len(goals[-1].actions)}"
                    self.map.add(path, item.at)
                    goals[-1].actions.append([])
                case BlockItem():
                    if not goals:
                        self.error("block before any [goal:...] and [action]", item.at)
                    if not goals[-1].actions:
                        self.error(
                            f"block before any [action] of goal {goals[-1].goalid!r}", item.at
                        )
                    g, a = len(goals) - 1, len(goals[-1].actions) - 1
                    path = block_path(g, a, len(goals[-1].actions[a]))
                    self.map.add(path, item.at)
                    if item.label is not None:
                        if item.label.value in labels:
                            line, column = labels[item.label.value][1]
                            self.error(
                                f"duplicate label {item.label.value!r} "
                                f"(first used at line {line}, column {column})",
                                item.label.at,
                            )
                        labels[item.label.value] = (path, item.label.at)
                    goals[-1].actions[a].append(self.block(item, path, jumps))
        targets = {jump.path: self.resolve(jump, labels) for jump in jumps}
        return Script(
            activityname=first.name.value,
            alfarulemessages=tuple(alfa),
            omegarulemessages=tuple(omega),
            goals=tuple(
                Goal(
                    goalid=goal.goalid,
                    actions=tuple(
                        Action(
                            blocks=tuple(
                                _with_targets(block, targets.get(block_path(g, a, b)))
                                for b, block in enumerate(blocks)
                            )
                        )
                        for a, blocks in enumerate(goal.actions)
                    ),
                )
                for g, goal in enumerate(goals)
            ),
        )

    def second_name(self, item: NameItem) -> NoReturn:
        word = item.name.value
        hint = did_you_mean(
            word,
            ["alfa:", "omega:", "goal:", "action"],
            shown=lambda item: "[action]" if item == "action" else f"[{item}...]",
        )
        self.error(f"unknown item [{word}]: the activity name was already given{hint}", item.at)

    def rule(self, item: RuleItem, path: str) -> RuleMessage:
        kind = "omega" if item.omega else "alfa"
        self.map.add(path, item.at)
        if len(item.fields) != len(RULE_FIELDS):
            self.error(
                f"[{kind}:...] needs {len(RULE_FIELDS)} fields "
                f"({', '.join(RULE_FIELDS)}), got {len(item.fields)}",
                item.at,
            )
        texts = [f if f is not None else Text("", item.at) for f in item.fields]
        for name, text in zip(RULE_FIELDS, texts, strict=True):
            self.map.add(f"{path}.{name}", text.at)
        code, ident, intopic, outtopic, action, mutex = texts
        rulecode = parse_int(code.value)
        if rulecode is None:
            self.error(f"rulecode: {not_a_number(code.value)}", code.at)
        return RuleMessage(
            rulecode=rulecode,
            id=ident.value,
            intopic=intopic.value,
            outtopic=outtopic.value,
            action=self.letter(action, RuleAction, "action"),
            mutexcmd=self.letter(mutex, MutexCmd, "mutexcmd"),
        )

    def letter(self, text: Text, enum: type[RuleAction] | type[MutexCmd], name: str):
        if text.value in enum.__members__:
            return enum[text.value]
        letters = ", ".join(enum.__members__)
        self.error(f"{name} must be one of {letters}, got {text.value!r}", text.at)

    def block(self, item: BlockItem, path: str, jumps: list[_PendingJump]) -> Block:
        match item.body:
            case InstBody():
                body = item.body
                if body.flag is not None:
                    self.map.add(f"{path}.flagged", body.flag.at)
                channels = {
                    spec.field: tuple(
                        spec.item(**self.values(token, spec, f"{path}.{spec.field}[{i}]"))
                        for i, token in enumerate(tokens)
                    )
                    for spec, tokens in zip(CHANNELS, body.channels, strict=True)
                }
                flagged = None if body.flag is None else body.flag.value
                return InstructionBlock(**channels, flagged=flagged)
            case JumpBody():
                body = item.body
                self.map.add(f"{path}.toparse", body.keyword_at, body.condition_at)
                true_at = body.truejump.at if body.truejump else body.true_at
                false_at = body.falsejump.at if body.falsejump else body.false_at
                self.map.add(f"{path}.truejump", true_at)
                self.map.add(f"{path}.falsejump", false_at)
                pending = _PendingJump(path, body.condition, body.truejump, body.falsejump)
                jumps.append(pending)
                return JumpBlock(toparse=body.condition)  # targets filled by finish()
            case SensorBody():
                return SensorBlock(request=item.body.request)
            case None:
                return TerminusBlock()
        raise AssertionError(item)

    def values(self, token: Token, spec: ChannelSpec, path: str) -> dict:
        """The fields of one quoted item string, numbers checked, positions recorded. A
        leading text field (a track's path) may hold commas: the numbers after it are
        split off from the right."""
        self.map.add(path, _pos(token))
        fields = dict(spec.item_fields())
        names, kind = tuple(fields), spec.channel.value
        raw = token.value[1:-1]
        column0 = (token.column or 1) + 1
        if fields[names[0]] is str:
            cuts = [m.start() for m in re.finditer(",", raw)][-(len(names) - 1) :]
            starts = [0, *(cut + 1 for cut in cuts)]
            ends = [*cuts, len(raw)]
            pieces = (
                [(start, raw[start:end]) for start, end in zip(starts, ends, strict=True)]
                if len(cuts) == len(names) - 1
                else None
            )
        else:
            pieces, start = [], 0
            for part in raw.split(","):
                pieces.append((start, part))
                start += len(part) + 1
        if pieces is None or len(pieces) != len(names):
            got = 1 + raw.count(",") if raw.strip() else 0
            self.error(
                f"{'an' if kind[0] in 'aeiou' else 'a'} {kind} needs {len(names)} values "
                f'"{", ".join(names)}", got {got}',
                _pos(token),
            )
        out: dict[str, object] = {}
        for name, (offset, piece) in zip(names, pieces, strict=True):
            lead = len(piece) - len(piece.lstrip())
            at = ((token.line or 1), column0 + offset + min(lead, max(len(piece) - 1, 0)))
            self.map.add(f"{path}.{name}", at)
            if fields[name] is str:
                out[name] = self.track(piece.strip(), at)
            elif fields[name] is int:
                number = parse_int(piece)
                if number is None:
                    if parse_float(piece) is not None:
                        self.error(f"{name} must be a whole number, got {piece.strip()}", at)
                    self.error(not_a_number(piece), at)
                out[name] = number
            else:
                value = parse_float(piece)
                if value is None:
                    self.error(not_a_number(piece), at)
                out[name] = value
        return out

    def track(self, raw: str, at: Position) -> str:
        try:
            return json.loads(f'"{raw}"', strict=False)
        except json.JSONDecodeError as error:
            self.error(f"bad escape in track path: {error.msg}", at)

    def resolve(
        self, jump: _PendingJump, labels: dict[str, tuple[str, Position]]
    ) -> tuple[str, str]:
        targets = []
        for label in (jump.truejump, jump.falsejump):
            if label is None or not label.value:
                targets.append("")
                continue
            if label.value not in labels:
                hint = did_you_mean(label.value, labels)
                self.error(f"jump to unknown label {label.value!r}{hint}", label.at)
            targets.append(labels[label.value][0])
        return targets[0], targets[1]


def _with_targets(block: Block, targets: tuple[str, str] | None) -> Block:
    if targets is None or not isinstance(block, JumpBlock):
        return block
    return JumpBlock(toparse=block.toparse, truejump=targets[0], falsejump=targets[1])


# --------------------------------------------------------------- syntax errors

_TERMINALS: Final = {
    "LSQB": "'['",
    "RSQB": "']'",
    "HASH": "'#'",
    "LPAR": "'('",
    "RPAR": "')'",
    "COLON": "':'",
    "COMMA": "','",
    "ALFA": "alfa:",
    "OMEGA": "omega:",
    "GOAL": "goal:",
    "ACTION": "action",
    "BLOCK": "b#",
    "INST": "blk_inst",
    "TERMINUS": "blk_terminus",
    "JUMP": "blk_jump",
    "SENSOR": "blk_sensor",
    **{f"{spec.dsl}_OPEN": f"{spec.dsl}(" for spec in CHANNELS},
    "FLG_OPEN": "FLG(",
    "CND_OPEN": "CND(",
    "TRJMP_OPEN": "TRJMP(",
    "FLSJMP_OPEN": "FLSJMP(",
    "NAME": "a name",
    "STRING": "a quoted string",
    "CND_CHUNK": "condition text",
    "SENS_TEXT": "request text",
    "$END": "the end of the file",
}
_BLOCK_KINDS: Final = {"INST", "TERMINUS", "JUMP", "SENSOR"}
_BLOCK_TYPES: Final = ("blk_inst", "blk_jump", "blk_terminus", "blk_sensor")
"""What a block's type is written as (``blk_sens`` too, which a hint need not offer)."""
_WORD: Final = re.compile(r"[^\s\[\]()\"%,]+")
_GLUED_KIND: Final = re.compile(r"(?<=#)blk_\w*$")


def _syntax_error(error: UnexpectedInput, text: str, source: str, lines: LineIndex) -> ScriptError:
    """A lark failure as a named, located ScriptError (see the table in the docs)."""
    expected: set[str] = set(
        getattr(error, "allowed", None) or getattr(error, "expected", None) or ()
    )
    expected -= {"WS", "COMMENT"}
    token = getattr(error, "token", None)
    at_end = token is not None and token.type == "$END"
    offset = len(text) if at_end else (error.pos_in_stream or 0)
    if at_end:
        offset = len(text.rstrip())
    char = text[offset] if offset < len(text) else ""
    word_match = _WORD.match(text, offset)
    word = word_match.group(0) if word_match else char
    glued = _GLUED_KIND.search(text, 0, offset + 1) if char.isalnum() or char == "_" else None
    if glued is not None and glued.end() >= offset:
        word_match = _WORD.match(text, glued.start())
        word, offset = (word_match.group(0) if word_match else word), glued.start()
        expected = set(_BLOCK_KINDS)
    opening = _last_open(text, offset, "[", "]")
    message = _describe(char, word, expected, at_end, opening, lines)
    line, column = lines.position(offset)
    if at_end and opening is not None and "never closed" in message:
        line, column = lines.position(opening)
    return ScriptError(
        message, source=source, line=line, column=column, context=lines.context(line, column)
    )


def _describe(
    char: str, word: str, expected: set[str], at_end: bool, opening: int | None, lines: LineIndex
) -> str:
    paren_open = "RPAR" in expected
    if char == '"':
        return 'unterminated string: a quoted string must end with " on the same line'
    if char == "%" and "CND_CHUNK" not in expected:
        return "unterminated comment: this '%' has no closing '%'"
    if expected & _BLOCK_KINDS and not at_end:
        word = word.removesuffix(":")  # the colon after the type is not part of it
        hint = did_you_mean(word, _BLOCK_TYPES, shown=str)
        return (
            f"unknown block type {word!r}; expected blk_inst, blk_jump, blk_terminus or"
            f" blk_sensor{hint}"
        )
    if at_end:
        if paren_open:
            return "unbalanced parentheses: ')' missing at the end of the file"
        if expected == {"LSQB"}:
            return "unexpected end of the file"
        return "unbalanced brackets: this '[' is never closed (']' missing)"
    if char == "[" and "RSQB" in expected:
        where = f" at line {lines.position(opening)[0]}" if opening is not None else ""
        return f"unbalanced brackets: ']' missing before this '[' (the item opened{where})"
    if char in "[]" and paren_open:
        return f"unbalanced parentheses: ')' missing before this '{char}'"
    if char == ")" and not paren_open:
        return "unbalanced parentheses: this ')' has no matching '('"
    if char == "]" and expected == {"LSQB"}:
        return "unbalanced brackets: this ']' has no matching '['"
    if expected == {"LSQB"}:
        return (
            f"unexpected text {word!r} outside brackets: items are written [like this] and "
            "comments % like this %"
        )
    if expected & {f"{spec.dsl}_OPEN" for spec in CHANNELS}:
        lists = " ".join(f"{spec.dsl}(...)" for spec in CHANNELS)
        return f"unexpected {word!r}: blk_inst needs {lists}, in this order (each may be empty)"
    if expected & {"CND_OPEN", "TRJMP_OPEN", "FLSJMP_OPEN"}:
        return (
            f"unexpected {word!r}: blk_jump needs CND(condition) TRJMP(label) FLSJMP(label), "
            "in this order"
        )
    if "ALFA" in expected:
        return f"unknown item starting {word!r}"
    if expected == {"HASH"}:
        return f"unexpected {word!r}: expected '#' after the label (a label has no spaces)"
    if "HASH" in expected and "NAME" in expected:
        return f'bad label {word!r}: a label has no spaces or any of []#:,"%()'
    names = " or ".join(sorted(_TERMINALS.get(name, name) for name in expected))
    return f"unexpected {word!r}; expected {names}"


def _last_open(text: str, offset: int, opening: str, closing: str) -> int | None:
    """Offset of the last ``opening`` before ``offset`` not closed before it."""
    depth = 0
    for index in range(min(offset, len(text)) - 1, -1, -1):
        if text[index] == closing:
            depth += 1
        elif text[index] == opening:
            if depth == 0:
                return index
            depth -= 1
    return None
