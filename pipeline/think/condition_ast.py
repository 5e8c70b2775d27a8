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
