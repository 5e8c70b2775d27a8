"""The rule condition language (thesis section 4.3): parser, typed AST and compiler to closures.

``compile_condition(text)`` parses once with lark (LALR), turns the tree into
typed nodes, checks every class, field, operator and function against the
registry, and builds Python closures; ``Condition.evaluate`` only runs them.
The language itself is described in ``docs/condition-language.md``.

Keys used in the stores (the map's ``aliases``/``variables``, the per-tick dict
and :attr:`Evaluation.bindings`) carry their sigil: ``"?child"`` (an alias, value
``"Human/c1"``), ``"@mood"`` (a variable), ``"?child$mood"`` (an attribute bound
to the alias ``?child``).
"""

from __future__ import annotations

import difflib
import enum
import functools
import json
import operator
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from importlib import resources
from typing import Final

import msgspec
from lark import Lark, Token, Transformer, v_args
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken, VisitError

from pipeline.messages import ActivityTracking, Human, Object, Obstacle, WorldMap
from pipeline.think.errors import RuleSyntaxError
from pipeline.think.functions import (
    CLASS_NAMES,
    ArgKind,
    Bound,
    Family,
    FunctionContext,
    FunctionRegistry,
    FunctionSpec,
    default_registry,
)

THIS: Final = "?THIS"
"""The entity under test inside a ``CLASS`` clause."""

_IDENT = re.compile(r"[A-Za-z_]\w*\Z")

_CLASS_TYPES: Final[dict[str, type]] = {
    "Human": Human,
    "Obstacle": Obstacle,
    "Object": Object,
    "Activity": ActivityTracking,
}
_SCALARS: Final = (bool, int, float, str)


def _scalar_fields(cls: type) -> dict[str, type]:
    return {
        f.name: f.type
        for f in msgspec.structs.fields(cls)
        if isinstance(f.type, type) and issubclass(f.type, _SCALARS)
    }


CLASS_FIELDS: Final[dict[str, dict[str, type]]] = {
    name: _scalar_fields(cls) for name, cls in _CLASS_TYPES.items()
}
"""The fields a comparison may name (``&field``), by class, with their types."""

_ALL_FIELDS: Final = sorted({f for fields in CLASS_FIELDS.values() for f in fields})


class Scope(enum.StrEnum):
    """How long a binding lives (thesis section 4.3)."""

    U = "U"
    """Until the script ends or a rule removes it: kept in the map (``aliases``/``variables``)."""
    T = "T"
    """Until the map returns to the Map Producer: kept in the per-tick dict the caller passes."""
    L = "L"
    """Only for this rule's evaluation and body: reported in the bindings, stored nowhere."""


class Op(enum.StrEnum):
    """Comparison operators (``OP`` prefix, since ``>`` is member access)."""

    EQ = "OP="
    LT = "OP<"
    GT = "OP>"


# ----------------------------------------------------------------------- the AST

Pos = tuple[int, int]
"""(line, column), both from 1."""


@dataclass(frozen=True)
class Literal:
    value: int | float | str
    text: str
    pos: Pos


@dataclass(frozen=True)
class AliasRef:
    alias: str
    pos: Pos


@dataclass(frozen=True)
class FieldRef:
    alias: str
    field: str
    pos: Pos


@dataclass(frozen=True)
class AttRef:
    alias: str
    att: str
    pos: Pos


@dataclass(frozen=True)
class VarRef:
    name: str
    pos: Pos


Operand = Literal | AliasRef | FieldRef | AttRef | VarRef


@dataclass(frozen=True)
class Call:
    family: str
    family_pos: Pos
    name: str
    name_pos: Pos
    args: tuple[Operand, ...]


@dataclass(frozen=True)
class Comparison:
    left: Operand
    op: Op
    right: Operand
    pos: Pos


Criterion = Call | Comparison


@dataclass(frozen=True)
class ClassClause:
    cls: str
    scope: Scope
    alias: str
    criteria: tuple[Criterion, ...]
    pos: Pos


@dataclass(frozen=True)
class VarClause:
    var: str
    scope: Scope
    call: Call
    pos: Pos


@dataclass(frozen=True)
class AttClause:
    alias: str
    att: str
    scope: Scope
    call: Call
    pos: Pos


@dataclass(frozen=True)
class EvalClause:
    call: Call
    pos: Pos


@dataclass(frozen=True)
class TrueClause:
    pos: Pos


Clause = ClassClause | VarClause | AttClause | EvalClause | TrueClause


@dataclass(frozen=True)
class ConditionAst:
    left: tuple[Clause, ...]
    right: tuple[Clause, ...]
    has_bang: bool
    bang_pos: Pos
    end_pos: Pos
    """Just after the last clause."""


# ------------------------------------------------------------------ parsing


def _error(message: str, pos: Pos) -> RuleSyntaxError:
    return RuleSyntaxError(message, line=pos[0], column=pos[1])


def _pos(token: Token) -> Pos:
    return (token.line or 1, token.column or 1)


def _name(token: Token, sigil_what: str, what: str) -> str:
    """Check ``?name``/``@name``/``$name``/``&name``/``#name``: a sigil then an identifier."""
    text = str(token)
    if not _IDENT.match(text[1:]):
        raise _error(
            f"bad {what} name {text!r}: {sigil_what} must be followed by a letter or '_',"
            " then letters, digits or '_'",
            _pos(token),
        )
    return text


def _alias(token: Token) -> str:
    return _name(token, "'?'", "alias")


def _scope(token: Token) -> Scope:
    if str(token) not in Scope.__members__:
        raise _error(f"bad scope {str(token)!r} (expected U, T or L)", _pos(token))
    return Scope(str(token))


def _family(token: Token) -> str:
    letter = str(token)[0]
    if letter not in Family.__members__:
        raise _error(f"unknown function family {str(token)!r} (expected B:, F: or E:)", _pos(token))
    return letter


@v_args(meta=True)
class _ToAst(Transformer):
    """lark tree -> typed nodes; token shapes are checked here, meaning in the compiler."""

    def with_bang(self, meta, children):
        left, bang, right = children
        ends = [c for c in (*right, *left) if c is not None]
        end = (meta.end_line, meta.end_column) if ends else (bang.end_line, bang.end_column)
        return ConditionAst(left, right, True, _pos(bang), end)

    def without_bang(self, meta, children):
        (clauses,) = children
        end = (meta.end_line, meta.end_column) if clauses else (1, 1)
        return ConditionAst(clauses, (), False, end, end)

    def clauses(self, meta, children):
        return tuple(c for c in children if c is not None)

    def class_clause(self, meta, children):
        _, cls_token, scope, alias, *criteria = children
        cls = str(cls_token)[1:]
        if cls not in CLASS_NAMES:
            known = ", ".join(f"#{c}" for c in CLASS_NAMES)
            raise _error(f"unknown class {str(cls_token)!r} (expected {known})", _pos(cls_token))
        name = _alias(alias)
        if name == THIS:
            raise _error("?THIS names the entity under test and cannot be bound", _pos(alias))
        return ClassClause(
            cls,
            _scope(scope),
            name,
            tuple(c for c in criteria if c is not None),
            (meta.line, meta.column),
        )

    def var_clause(self, meta, children):
        _, var, scope, family, call = children
        name = _name(var, "'@'", "variable")
        return VarClause(name, _scope(scope), self._call(family, call), (meta.line, meta.column))

    def att_clause(self, meta, children):
        _, alias, att, scope, family, call = children
        return AttClause(
            _alias(alias),
            _name(att, "'$'", "attribute")[1:],
            _scope(scope),
            self._call(family, call),
            (meta.line, meta.column),
        )

    def eval_clause(self, meta, children):
        family, call = children
        return EvalClause(self._call(family, call), (meta.line, meta.column))

    def true_clause(self, meta, children):
        return TrueClause((meta.line, meta.column))

    def fn_criterion(self, meta, children):
        family, call = children
        return self._call(family, call)

    def cmp_criterion(self, meta, children):
        left, op, right = children
        if str(op) not in Op._value2member_map_:
            raise _error(f"unknown operator {str(op)!r} (expected OP=, OP< or OP>)", _pos(op))
        return Comparison(left, Op(str(op)), right, _pos(op))

    @staticmethod
    def _call(family: Token, call: tuple[Token, tuple[Operand, ...]]) -> Call:
        name, args = call
        return Call(_family(family), _pos(family), str(name), _pos(name), args)

    def call(self, meta, children):
        name, *args = children
        return (name, tuple(a for a in args if a is not None))

    def number(self, meta, children):
        (token,) = children
        text = str(token)
        plain = text.lstrip("+-")
        value: int | float = int(text) if plain.isdigit() else float(text)
        return Literal(value, text, _pos(token))

    def string(self, meta, children):
        (token,) = children
        try:
            value = json.loads(str(token))
        except ValueError:
            raise _error(f"bad string literal {token!s}", _pos(token)) from None
        return Literal(value, value, _pos(token))

    def word(self, meta, children):
        (token,) = children
        return Literal(str(token), str(token), _pos(token))

    def alias(self, meta, children):
        (token,) = children
        return AliasRef(_alias(token), _pos(token))

    def alias_field(self, meta, children):
        alias, field = children
        return FieldRef(_alias(alias), _name(field, "'&'", "field")[1:], _pos(alias))

    def alias_att(self, meta, children):
        alias, att = children
        return AttRef(_alias(alias), _name(att, "'$'", "attribute")[1:], _pos(alias))

    def variable(self, meta, children):
        (token,) = children
        return VarRef(_name(token, "'@'", "variable"), _pos(token))


@functools.cache
def _parser() -> Lark:
    grammar = resources.files(__package__).joinpath("condition.lark").read_text(encoding="utf-8")
    return Lark(grammar, parser="lalr", propagate_positions=True, maybe_placeholders=True)


_TERMINALS: Final = {
    "LBRACE": "'{'",
    "RBRACE": "'}'",
    "COMMA": "','",
    "BANG": "'!'",
    "LPAR": "'('",
    "RPAR": "')'",
    "MORETHAN": "'>'",
    "CLASS": "CLASS",
    "VAR": "VAR",
    "ATT": "ATT",
    "TRUE": "TRUE",
    "FAMILY": "a family (B:, F: or E:)",
    "OPERATOR": "an operator (OP=, OP< or OP>)",
    "SCOPE": "a scope (U, T or L)",
    "NAME": "a name",
    "CLASSNAME": "a class (#Human, #Obstacle, #Object or #Activity)",
    "ALIAS": "an alias (?name)",
    "VARNAME": "a variable (@name)",
    "ATTNAME": "an attribute ($name)",
    "FIELDNAME": "a field (&name)",
    "NUMBER": "a number",
    "STRING": "a string",
    "$END": "the end of the condition",
}


def _expected(names: Sequence[str]) -> str:
    shown = sorted({_TERMINALS.get(n, n) for n in names})
    if len(shown) <= 1:
        return "".join(shown)
    return ", ".join(shown[:-1]) + " or " + shown[-1]


def _end_pos(text: str) -> Pos:
    lines = text.split("\n")
    return (len(lines), len(lines[-1]) + 1)


def _syntax_error(text: str, exc: UnexpectedInput) -> RuleSyntaxError:
    if isinstance(exc, UnexpectedCharacters):
        pos = (exc.line, exc.column)
        char = text[exc.pos_in_stream] if exc.pos_in_stream < len(text) else ""
        hint = f"; expected {_expected(exc.allowed)}" if exc.allowed else ""
        return _error(f"unexpected character {char!r}{hint}", pos)
    if isinstance(exc, UnexpectedToken):
        token = exc.token
        expected = exc.expected
        if token.type == "$END":
            pos = _end_pos(text)
            if "RBRACE" in expected or "RPAR" in expected:
                closing = "'}'" if "RBRACE" in expected else "')'"
                return _error(f"unbalanced braces: missing {closing} at the end", pos)
            return _error(f"unexpected end of the condition; expected {_expected(expected)}", pos)
        pos = _pos(token)
        if token.type == "RBRACE":
            return _error(
                f"unbalanced braces: unexpected '}}'; expected {_expected(expected)}", pos
            )
        if token.type == "MORETHAN" and "OPERATOR" in expected:
            return _error("a comparison is written OP>, OP< or OP= ('>' is member access)", pos)
        if token.type == "LBRACE" and "BANG" in expected:
            return _error("expected ',' or '!' between clauses, got '{'", pos)
        if token.type == "LBRACE" and "RBRACE" in expected:
            return _error("unbalanced braces: '{' inside a clause (missing '}'?)", pos)
        return _error(f"unexpected {str(token)!r}; expected {_expected(expected)}", pos)
    pos = (getattr(exc, "line", 1) or 1, getattr(exc, "column", 1) or 1)
    return _error(f"cannot parse the condition: {exc}", pos)


def parse_condition(text: str) -> ConditionAst:
    """The typed AST of ``text`` (shapes checked; functions and fields are checked by compile)."""
    if not text.strip():
        raise _error("empty condition (write {TRUE} or '! {TRUE}' for one always true)", (1, 1))
    try:
        tree = _parser().parse(text)
    except UnexpectedInput as exc:
        raise _syntax_error(text, exc) from None
    try:
        return _ToAst().transform(tree)
    except VisitError as exc:
        if isinstance(exc.orig_exc, RuleSyntaxError):
            raise exc.orig_exc from None
        raise


# ----------------------------------------------------------------- evaluation state

_MISSING: Final = object()
"""A value that could not be found or cast: the criterion, call or assignment fails."""


def entity_ref(cls: str, entity: Bound) -> str:
    """``"Human/c1"``: how an alias names its entity (activities by ``activityname``)."""
    key = entity.activityname if isinstance(entity, ActivityTracking) else entity.id
    return f"{cls}/{key}"


def _entities(world_map: WorldMap, cls: str) -> Sequence[Bound]:
    if cls == "Human":
        return world_map.humans
    if cls == "Obstacle":
        return world_map.obstacles
    if cls == "Object":
        return world_map.objects
    if cls == "Activity":
        return world_map.robotstatus.activities
    return ()


def find_entity(world_map: WorldMap, ref: str) -> Bound | None:
    """The entity named by ``ref`` (``"Human/c1"``), or ``None`` when it is not in the map."""
    cls = ref.partition("/")[0]
    for entity in _entities(world_map, cls):
        if entity_ref(cls, entity) == ref:
            return entity
    return None


def _is_alias_key(key: str) -> bool:
    return key.startswith("?") and "$" not in key


def release_alias(
    world_map: WorldMap, alias: str, tick_scope: dict[str, str] | None = None
) -> None:
    """Remove ``alias`` and the attributes bound to it from the map (scope U) and ``tick_scope``."""
    for store in (world_map.aliases, world_map.variables, tick_scope or {}):
        for key in [k for k in store if k == alias or k.startswith(alias + "$")]:
            del store[key]


class _Run:
    """The state of one evaluation."""

    __slots__ = ("_ctx", "bindings", "local", "now_ms", "tick", "world_map")

    def __init__(self, world_map: WorldMap, now_ms: int, tick: dict[str, str]):
        self.world_map = world_map
        self.now_ms = now_ms
        self._ctx: FunctionContext | None = None
        self.tick = tick
        self.local: dict[str, str] = {}
        self.bindings: dict[str, str] = {}

    @property
    def ctx(self) -> FunctionContext:
        """What rule functions see; made on the first call (many conditions call none)."""
        if self._ctx is None:
            self._ctx = FunctionContext(world_map=self.world_map, now_ms=self.now_ms)
        return self._ctx

    def store(self, scope: Scope) -> dict[str, str]:
        if scope is Scope.U:
            return self.world_map.variables
        return self.tick if scope is Scope.T else self.local

    def alias_store(self, scope: Scope) -> dict[str, str]:
        return self.world_map.aliases if scope is Scope.U else self.store(scope)

    def lookup(self, key: str, stores: tuple[dict[str, str], ...]) -> str | None:
        for store in stores:
            value = store.get(key)
            if value is not None:
                return value
        return None

    def alias_ref(self, alias: str) -> str | None:
        return self.lookup(alias, (self.local, self.tick, self.world_map.aliases))

    def entity(self, alias: str) -> Bound | None:
        ref = self.alias_ref(alias)
        return None if ref is None else find_entity(self.world_map, ref)

    def variable(self, name: str) -> str | None:
        return self.lookup(name, (self.local, self.tick, self.world_map.variables))

    def attribute(self, alias: str, att: str) -> object:
        value = self.lookup(f"{alias}${att}", (self.local, self.tick, self.world_map.variables))
        if value is not None:
            return value
        entity = self.entity(alias)
        attributes = getattr(entity, "attributes", None)
        if attributes is None or att not in attributes:
            return _MISSING
        return attributes[att]

    def unbind_alias(self, alias: str) -> None:
        for store in (self.local, self.tick, self.world_map.aliases, self.world_map.variables):
            for key in [k for k in store if k == alias or k.startswith(alias + "$")]:
                del store[key]

    def taken(self, alias: str) -> set[str]:
        """Entities already bound to another live alias."""
        return {
            ref
            for store in (self.local, self.tick, self.world_map.aliases)
            for key, ref in store.items()
            if key != alias and _is_alias_key(key)
        }


# ---------------------------------------------------------------------- casting


def _to_number(value: object) -> object:
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, int | float):
        return value
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return _MISSING
    return _MISSING


_TRUE_TEXTS: Final = {"true": True, "1": True, "false": False, "0": False}


def _to_bool(value: object) -> object:
    if isinstance(value, bool):
        return value
    if isinstance(value, int | float):
        return value != 0
    if isinstance(value, str):
        return _TRUE_TEXTS.get(value.strip().lower(), _MISSING)
    return _MISSING


def _to_text(value: object) -> object:
    if isinstance(value, str):
        return value
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return str(int(value)) if value.is_integer() else repr(value)
    return _MISSING


def _compare(left: object, op: Op, right: object) -> bool:
    """Compare a field with a value cast to the field's type (numbers compare numerically)."""
    if right is _MISSING or left is _MISSING:
        return False
    if isinstance(left, bool):
        right = _to_bool(right)
    elif isinstance(left, int | float):
        right = _to_number(right)
    elif isinstance(right, int | float) and not isinstance(right, bool):
        left = _to_number(left)
    else:
        right = _to_text(right)
    if left is _MISSING or right is _MISSING:
        return False
    try:
        if op is Op.EQ:
            return left == right
        if op is Op.LT:
            return left < right  # type: ignore[operator]
        return left > right  # type: ignore[operator]
    except TypeError:
        return False


_NUMBER_OPS: Final[dict[Op, Callable[[float, float], bool]]] = {
    Op.EQ: operator.eq,
    Op.LT: operator.lt,
    Op.GT: operator.gt,
}
"""What ``_compare`` does for two numbers."""

# -------------------------------------------------------------------- compiling

Getter = Callable[[_Run, Bound | None], object]
_GO, _FAIL, _TRUE = 0, 1, 2
Step = Callable[[_Run], int]


def _suggest(name: str, options: Sequence[str]) -> str:
    close = difflib.get_close_matches(name, options, n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


class _Compiler:
    def __init__(self, registry: FunctionRegistry):
        self.registry = registry

    # operands ---------------------------------------------------------------------

    def field_type(self, ref: FieldRef, this_cls: str | None) -> type | None:
        if ref.alias == THIS:
            assert this_cls is not None
            fields = CLASS_FIELDS[this_cls]
            if ref.field not in fields:
                raise _error(
                    f"unknown field '&{ref.field}' of #{this_cls} (fields: {', '.join(fields)})",
                    ref.pos,
                )
            return fields[ref.field]
        if ref.field not in _ALL_FIELDS:
            raise _error(f"unknown field '&{ref.field}'{_suggest(ref.field, _ALL_FIELDS)}", ref.pos)
        return None

    def operand(
        self,
        node: Operand,
        this_cls: str | None,
        kind: ArgKind = ArgKind.ANY,
        accepts: tuple[type, ...] = (),
    ) -> Getter:
        alias = getattr(node, "alias", None)
        if alias == THIS and this_cls is None:
            raise _error("?THIS can only be used inside a CLASS clause", node.pos)
        if isinstance(node, AliasRef):
            if kind not in (ArgKind.ENTITY, ArgKind.OPTIONAL_ENTITY):
                raise _error(f"expected {kind.value} here, got the alias {node.alias}", node.pos)
            optional = kind is ArgKind.OPTIONAL_ENTITY
            accepted = accepts or (object,)
            if node.alias == THIS:
                return lambda run, this: this if isinstance(this, accepted) else _MISSING

            def entity(run: _Run, this: Bound | None, _a: str = node.alias) -> object:
                found = run.entity(_a)
                if found is None:
                    return None if optional else _MISSING
                return found if isinstance(found, accepted) else _MISSING

            return entity
        if kind in (ArgKind.ENTITY, ArgKind.OPTIONAL_ENTITY):
            raise _error(f"expected {kind.value} here", node.pos)
        getter = self.value(node, this_cls)
        if kind is ArgKind.NUMBER:
            if isinstance(node, Literal) and isinstance(node.value, str):
                raise _error(f"expected a number here, got {node.text!r}", node.pos)
            return lambda run, this: _to_number(getter(run, this))
        if kind is ArgKind.TEXT:
            if isinstance(node, Literal):
                text = node.text
                return lambda run, this: text
            return lambda run, this: _to_text(getter(run, this))
        return getter

    def value(self, node: Operand, this_cls: str | None) -> Getter:
        if isinstance(node, Literal):
            value = node.value
            return lambda run, this: value
        if isinstance(node, FieldRef):
            self.field_type(node, this_cls)
            field = node.field
            if node.alias == THIS:
                return lambda run, this: getattr(this, field)

            def other_field(run: _Run, this: Bound | None, _a: str = node.alias) -> object:
                return getattr(run.entity(_a), field, _MISSING)

            return other_field
        if isinstance(node, AttRef):
            att = node.att
            if node.alias == THIS:

                def this_att(run: _Run, this: Bound | None) -> object:
                    attributes = getattr(this, "attributes", None) or {}
                    return attributes.get(att, _MISSING)

                return this_att
            return lambda run, this, _a=node.alias: run.attribute(_a, att)
        if isinstance(node, VarRef):
            name = node.name

            def variable(run: _Run, this: Bound | None) -> object:
                value = run.variable(name)
                return _MISSING if value is None else value

            return variable
        raise _error(
            f"compare with {node.alias}>&field or {node.alias}>$attribute, not a bare alias",
            node.pos,
        )

    # calls ------------------------------------------------------------------------

    def call(self, call: Call, family: Family, this_cls: str | None = None) -> Getter:
        where = {
            Family.B: "a CLASS criterion takes a B: function",
            Family.F: "a VAR or ATT clause takes an F: function",
            Family.E: "an evaluation clause takes an E: function",
        }[family]
        if call.family != family:
            raise _error(f"{where}, not {call.family}:", call.family_pos)
        spec = self.registry.get(call.name)
        if spec is None:
            raise _error(
                f"unknown function {call.name!r}{_suggest(call.name, self.registry.names())}",
                call.name_pos,
            )
        if spec.family is not family:
            raise _error(
                f"{call.name!r} is a {spec.family}: function, not {family}: ({where})",
                call.name_pos,
            )
        count = len(call.args)
        if count < spec.min_args or (spec.max_args is not None and count > spec.max_args):
            raise _error(
                f"{call.name!r} takes {spec.arity_text()} argument(s), got {count}:"
                f" {spec.signature}",
                call.name_pos,
            )
        if family is Family.B and this_cls not in spec.classes:
            only = ", ".join(f"#{c}" for c in spec.classes)
            raise _error(
                f"{call.name!r} does not apply to #{this_cls} (only {only})", call.name_pos
            )
        getters = tuple(
            self.operand(arg, this_cls, spec.kind(i), spec.accepts(i))
            for i, arg in enumerate(call.args)
        )
        return _bind_call(spec, getters)

    # clauses ----------------------------------------------------------------------

    def criterion(self, node: Criterion, cls: str) -> Callable[[_Run, Bound], bool]:
        if isinstance(node, Call):
            call = self.call(node, Family.B, cls)
            return lambda run, this: call(run, this) is True
        left = node.left
        if not (isinstance(left, FieldRef) and left.alias == THIS):
            raise _error("the left of a comparison must be ?THIS>&field", left.pos)
        self.field_type(left, cls)
        field = left.field
        op = node.op
        literal = node.right.value if isinstance(node.right, Literal) else None
        if isinstance(literal, int | float) and not isinstance(literal, bool):
            # The common ``?THIS>&positionrho OP< 0.8``: a number field against a number
            # needs none of _compare's casts, so compare at once (others take _compare).
            compare = _NUMBER_OPS[op]

            def number_criterion(run: _Run, this: Bound) -> bool:
                value = getattr(this, field)
                if type(value) is float or type(value) is int:
                    return compare(value, literal)
                return _compare(value, op, literal)

            return number_criterion
        right = self.value(node.right, cls)
        return lambda run, this: _compare(getattr(this, field), op, right(run, this))

    def clause(self, node: Clause, left_side: bool) -> Step:
        if isinstance(node, TrueClause):
            return lambda run: _TRUE
        if left_side and isinstance(node, EvalClause):
            raise _error("E: evaluations belong after '!'", node.pos)
        if not left_side and not isinstance(node, EvalClause):
            raise _error("assignments (CLASS, VAR, ATT) belong before '!'", node.pos)
        if isinstance(node, EvalClause):
            call = self.call(node.call, Family.E)
            return lambda run: _GO if call(run, None) is True else _FAIL
        if isinstance(node, ClassClause):
            return _class_step(node, tuple(self.criterion(c, node.cls) for c in node.criteria))
        if isinstance(node, VarClause):
            return _assign_step(node.var, node.scope, self.call(node.call, Family.F), None)
        call = self.call(node.call, Family.F)
        return _assign_step(f"{node.alias}${node.att}", node.scope, call, node.alias)


def _bind_call(spec: FunctionSpec, getters: tuple[Getter, ...]) -> Getter:
    fn = spec.fn
    with_entity = spec.family is Family.B
    if not getters:  # ``B: infront ()``, ``E: camera_offline ()``: no arguments to gather
        if with_entity:
            return lambda run, this: fn(run.ctx, this)
        return lambda run, this: fn(run.ctx)

    def run_call(run: _Run, this: Bound | None) -> object:
        args = []
        for get in getters:
            value = get(run, this)
            if value is _MISSING:
                return _MISSING
            args.append(value)
        if with_entity:
            return fn(run.ctx, this, *args)
        return fn(run.ctx, *args)

    return run_call


def _class_step(node: ClassClause, criteria: tuple[Callable[[_Run, Bound], bool], ...]) -> Step:
    cls, alias, scope = node.cls, node.alias, node.scope

    def meets(run: _Run, entity: Bound) -> bool:
        for criterion in criteria:  # noqa: SIM110 (a plain loop: all() over a generator costs more)
            if not criterion(run, entity):
                return False
        return True

    def step(run: _Run) -> int:
        ref = run.alias_ref(alias)
        if ref is not None:
            entity = find_entity(run.world_map, ref) if ref.startswith(cls + "/") else None
            if entity is not None and meets(run, entity):
                run.bindings[alias] = ref
                return _GO
            run.unbind_alias(alias)
        taken = run.taken(alias)
        best: Bound | None = None
        for entity in _entities(run.world_map, cls):
            if best is not None and entity.creationtime >= best.creationtime:
                continue
            if taken and entity_ref(cls, entity) in taken:  # no ref to build when none is
                continue
            if not meets(run, entity):
                continue
            best = entity
        if best is None:
            return _FAIL
        ref = entity_ref(cls, best)
        run.alias_store(scope)[alias] = ref
        run.bindings[alias] = ref
        return _GO

    return step


def _assign_step(key: str, scope: Scope, call: Getter, alias: str | None) -> Step:
    def step(run: _Run) -> int:
        if alias is not None and run.entity(alias) is None:
            return _FAIL
        value = call(run, None)
        text = _MISSING if value is None or value is _MISSING else _to_text(value)
        if text is _MISSING:
            return _FAIL
        assert isinstance(text, str)
        run.store(scope)[key] = text
        run.bindings[key] = text
        return _GO

    return step


# ------------------------------------------------------------------- public API


class Evaluation(msgspec.Struct, frozen=True, kw_only=True):
    """The outcome of evaluating a condition once."""

    result: bool
    bindings: dict[str, str] = {}
    """Every alias, variable and attribute bound during the evaluation, in binding order:
    ``"?child" -> "Human/c1"``, ``"@mood" -> "happy"``, ``"?child$mood" -> "calm"``."""

    def entity(self, world_map: WorldMap, alias: str) -> Bound | None:
        """The map entity bound to ``alias`` by this evaluation, or ``None``."""
        ref = self.bindings.get(alias)
        return None if ref is None or not _is_alias_key(alias) else find_entity(world_map, ref)


class Condition:
    """A compiled condition: closures only, no parsing at evaluation time."""

    __slots__ = ("_steps", "aliases", "registry_version", "text")

    def __init__(self, text: str, steps: tuple[Step, ...], aliases: tuple[str, ...], version: str):
        self.text = text
        self._steps = steps
        self.aliases = aliases
        """Aliases the condition's CLASS clauses bind, in order."""
        self.registry_version = version

    def evaluate(
        self, world_map: WorldMap, *, now_ms: int, tick_scope: dict[str, str] | None = None
    ) -> Evaluation:
        """Run the clauses left to right on ``world_map`` (writes scopes U and T, see module doc).

        Without ``tick_scope``, T-scope bindings last only for this evaluation.
        """
        run = _Run(world_map, now_ms, {} if tick_scope is None else tick_scope)
        result = True
        for step in self._steps:
            outcome = step(run)
            if outcome == _FAIL:
                result = False
                break
            if outcome == _TRUE:
                break
        return Evaluation(result=result, bindings=run.bindings)  # the run ends here: no copy

    def __repr__(self) -> str:
        return f"Condition({self.text!r})"


def compile_condition(text: str, *, registry: FunctionRegistry | None = None) -> Condition:
    """Parse, check and compile ``text``; raises :class:`RuleSyntaxError` (``<condition>:L:C``)."""
    registry = registry or default_registry()
    ast = parse_condition(text)
    if not ast.has_bang:
        if ast.left and isinstance(ast.left[0], TrueClause) and len(ast.left) == 1:
            return Condition(text, (lambda run: _TRUE,), (), registry.version)
        if not ast.left:
            raise _error("empty condition", (1, 1))
        first_eval = next((c for c in ast.left if isinstance(c, EvalClause)), None)
        pos = first_eval.pos if first_eval is not None else ast.end_pos
        raise _error(
            "missing '!' between the assignments and the evaluations"
            " (only {TRUE} stands without '!')",
            pos,
        )
    compiler = _Compiler(registry)
    steps = tuple(compiler.clause(c, True) for c in ast.left)
    steps += tuple(compiler.clause(c, False) for c in ast.right)
    aliases = tuple(c.alias for c in ast.left if isinstance(c, ClassClause))
    return Condition(text, steps, aliases, registry.version)


__all__ = [
    "CLASS_FIELDS",
    "Condition",
    "Evaluation",
    "Op",
    "RuleSyntaxError",
    "Scope",
    "compile_condition",
    "entity_ref",
    "find_entity",
    "parse_condition",
    "release_alias",
]
