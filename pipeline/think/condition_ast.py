"""The condition language's typed AST (thesis 4.3): scopes, operators, clauses and their places.

The parser (``condition_parse``) builds these nodes; the compiler
(``condition_compile``) turns them into closures. Nothing here runs a condition.
"""

from __future__ import annotations

import enum
import re
from dataclasses import dataclass
from typing import Final

import msgspec
from lark import Token
from oimi.pipeline.messages import ACTIVITY_CLASS, ENTITY_LISTS, ActivityTracking
from oimi.pipeline.think.errors import RuleSyntaxError

THIS: Final = "?THIS"
"""The entity under test inside a ``CLASS`` clause."""

IDENT = re.compile(r"[A-Za-z_]\w*\Z")
"""A field's or a function's name."""
PUNCTUATION: Final = '?@"$&#{}(),>!'
"""The language's own punctuation, which ends a name (``condition.lark`` says it too)."""
USER_NAME: Final = re.compile(rf"[^\s/{re.escape(PUNCTUATION)}]+\Z")
"""A name the designer makes up, of an alias, a variable or an attribute: thesis 4.3, "any
string without ' ' / '/' chars", less the language's own punctuation."""
USER_NAME_CHARACTERS: Final = f"whitespace, '/' or any of {PUNCTUATION}"
"""What :data:`USER_NAME` may not hold, as an error message says it."""

CLASS_TYPES: Final[dict[str, type]] = {
    **{m.name: m.struct for m in ENTITY_LISTS},
    ACTIVITY_CLASS: ActivityTracking,
}
_SCALARS: Final = (bool, int, float, str)


def _scalar_fields(cls: type) -> dict[str, type]:
    return {
        f.name: f.type
        for f in msgspec.structs.fields(cls)
        if isinstance(f.type, type) and issubclass(f.type, _SCALARS)
    }


CLASS_FIELDS: Final[dict[str, dict[str, type]]] = {
    name: _scalar_fields(cls) for name, cls in CLASS_TYPES.items()
}
"""The fields a comparison may name (``&field``), by class, with their types."""

ALL_FIELDS: Final = sorted({f for fields in CLASS_FIELDS.values() for f in fields})


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


def located(message: str, pos: Pos) -> RuleSyntaxError:
    return RuleSyntaxError(message, line=pos[0], column=pos[1])


def token_pos(token: Token) -> Pos:
    return (token.line or 1, token.column or 1)


def bound_aliases(ast: ConditionAst) -> list[str]:
    """The aliases the condition's ``CLASS`` clauses bind, in order."""
    return [c.alias for c in (*ast.left, *ast.right) if isinstance(c, ClassClause)]


def unbound_aliases(ast: ConditionAst) -> list[tuple[str, Pos]]:
    """Each alias the condition reads (with its first place) that none of its ``CLASS``
    clauses binds: it has a value only where another rule bound it in scope ``U`` (a
    mistyped alias reads as one that is never bound)."""
    bound = {THIS, *bound_aliases(ast)}
    read: dict[str, Pos] = {}
    for clause in (*ast.left, *ast.right):
        for alias, pos in _aliases_read(clause):
            if alias not in bound:
                read.setdefault(alias, pos)
    return list(read.items())


def _aliases_read(clause: Clause) -> list[tuple[str, Pos]]:
    """The aliases a clause reads: in its criteria's and calls' operands, and the alias
    an ``ATT`` clause binds its attribute to."""
    match clause:
        case ClassClause(criteria=criteria):
            calls = [c for c in criteria if isinstance(c, Call)]
            operands = [o for c in criteria if isinstance(c, Comparison) for o in (c.left, c.right)]
        case AttClause(call=call):
            calls, operands = [call], []
        case VarClause(call=call) | EvalClause(call=call):
            calls, operands = [call], []
        case _:
            return []
    operands += [arg for call in calls for arg in call.args]
    found = [(o.alias, o.pos) for o in operands if isinstance(o, AliasRef | FieldRef | AttRef)]
    if isinstance(clause, AttClause):
        found.insert(0, (clause.alias, clause.pos))
    return found
