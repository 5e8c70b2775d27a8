"""Parsing the condition language with lark (LALR) into the typed AST of ``condition_ast``.

Parse failures are mapped to named errors placed at a line and column; the
terminal names lark reports are translated by one table (``TERMINALS``).
"""

from __future__ import annotations

import functools
import json
import re
from collections.abc import Sequence
from importlib import resources
from typing import Final

from lark import Lark, Token, Transformer, v_args
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken, VisitError
from oimi.pipeline.texts import did_you_mean
from oimi.pipeline.think.condition_ast import (
    IDENT,
    THIS,
    USER_NAME,
    USER_NAME_CHARACTERS,
    AliasRef,
    AttClause,
    AttRef,
    Call,
    ClassClause,
    Comparison,
    ConditionAst,
    EvalClause,
    FieldRef,
    Literal,
    Op,
    Operand,
    Pos,
    Scope,
    TrueClause,
    VarClause,
    VarRef,
    located,
    token_pos,
)
from oimi.pipeline.think.errors import RuleSyntaxError
from oimi.pipeline.think.functions import (
    CLASS_NAMES,
    Family,
)


def _name(token: Token, sigil_what: str, what: str) -> str:
    """Check ``?name``/``@name``/``$name``/``&name``/``#name``: a sigil then an identifier."""
    text = str(token)
    if not IDENT.match(text[1:]):
        raise located(
            f"bad {what} name {text!r}: {sigil_what} must be followed by a letter or '_',"
            " then letters, digits or '_'",
            token_pos(token),
        )
    return text


def _user_name(token: Token, what: str) -> str:
    """Check ``?name``/``@name``/``$name``: a sigil then a name of the designer's."""
    text = str(token)
    if not USER_NAME.match(text[1:]):
        raise located(
            f"bad {what} name {text!r}: '{text[0]}' must be followed by a name without "
            + USER_NAME_CHARACTERS,
            token_pos(token),
        )
    return text


def _alias(token: Token) -> str:
    return _user_name(token, "alias")


def _scope(token: Token) -> Scope:
    if str(token) not in Scope.__members__:
        raise located(f"bad scope {str(token)!r} (expected U, T or L)", token_pos(token))
    return Scope(str(token))


def _family(token: Token) -> str:
    letter = str(token)[0]
    if letter not in Family.__members__:
        raise located(
            f"unknown function family {str(token)!r} (expected B:, F: or E:)", token_pos(token)
        )
    return letter


@v_args(meta=True)
class _ToAst(Transformer):
    """lark tree -> typed nodes; token shapes are checked here, meaning in the compiler."""

    def with_bang(self, meta, children):
        left, bang, right = children
        ends = [c for c in (*right, *left) if c is not None]
        end = (meta.end_line, meta.end_column) if ends else (bang.end_line, bang.end_column)
        return ConditionAst(left, right, True, token_pos(bang), end)

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
            hint = did_you_mean(cls, CLASS_NAMES, shown=lambda name: f"#{name}")
            raise located(
                f"unknown class {str(cls_token)!r} (expected {known}){hint}", token_pos(cls_token)
            )
        name = _alias(alias)
        if name == THIS:
            raise located("?THIS names the entity under test and cannot be bound", token_pos(alias))
        return ClassClause(
            cls,
            _scope(scope),
            name,
            tuple(c for c in criteria if c is not None),
            (meta.line, meta.column),
        )

    def var_clause(self, meta, children):
        _, var, scope, family, call = children
        name = _user_name(var, "variable")
        return VarClause(name, _scope(scope), self._call(family, call), (meta.line, meta.column))

    def att_clause(self, meta, children):
        _, alias, att, scope, family, call = children
        return AttClause(
            _alias(alias),
            _user_name(att, "attribute")[1:],
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
            raise located(f"unknown operator {str(op)!r} (expected OP=, OP< or OP>)", token_pos(op))
        return Comparison(left, Op(str(op)), right, token_pos(op))

    @staticmethod
    def _call(family: Token, call: tuple[Token, tuple[Operand, ...]]) -> Call:
        name, args = call
        return Call(_family(family), token_pos(family), str(name), token_pos(name), args)

    def call(self, meta, children):
        name, *args = children
        return (name, tuple(a for a in args if a is not None))

    def number(self, meta, children):
        (token,) = children
        text = str(token)
        plain = text.lstrip("+-")
        value: int | float = int(text) if plain.isdigit() else float(text)
        return Literal(value, text, token_pos(token))

    def string(self, meta, children):
        (token,) = children
        try:
            value = json.loads(str(token))
        except ValueError:
            raise located(f"bad string literal {token!s}", token_pos(token)) from None
        return Literal(value, value, token_pos(token))

    def word(self, meta, children):
        (token,) = children
        return Literal(str(token), str(token), token_pos(token))

    def alias(self, meta, children):
        (token,) = children
        return AliasRef(_alias(token), token_pos(token))

    def alias_field(self, meta, children):
        alias, field = children
        return FieldRef(_alias(alias), _name(field, "'&'", "field")[1:], token_pos(alias))

    def alias_att(self, meta, children):
        alias, att = children
        return AttRef(_alias(alias), _user_name(att, "attribute")[1:], token_pos(alias))

    def variable(self, meta, children):
        (token,) = children
        return VarRef(_user_name(token, "variable"), token_pos(token))


@functools.cache
def _parser() -> Lark:
    grammar = resources.files(__package__).joinpath("condition.lark").read_text(encoding="utf-8")
    return Lark(grammar, parser="lalr", propagate_positions=True, maybe_placeholders=True)


TERMINALS: Final = {
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
    shown = sorted({TERMINALS.get(n, n) for n in names})
    if len(shown) <= 1:
        return "".join(shown)
    return ", ".join(shown[:-1]) + " or " + shown[-1]


def _end_pos(text: str) -> Pos:
    lines = text.split("\n")
    return (len(lines), len(lines[-1]) + 1)


_NUMBER_BEFORE: Final = re.compile(r"(?:^|(?<=[\s(,]))[+-]?\d+(?:\.\d*)?(?:[eE][+-]?\d+)?\Z")
"""A number that ends where an unexpected token starts."""
_WORD: Final = re.compile(r"[^\s(),{}]*")


def _glued_number(text: str, token: Token) -> tuple[str, int] | None:
    """``(word, its number's length)`` when ``token`` starts right after a number, as in
    ``1.0x`` or ``1.0.5`` (the word from the number to the next delimiter); else None."""
    start = token.start_pos
    if start is None or start == 0 or text[start - 1].isspace():
        return None
    number = _NUMBER_BEFORE.search(text, 0, start)
    if number is None:
        return None
    rest = _WORD.match(text, start).group()  # type: ignore[union-attr]
    return (number.group() + rest, start - number.start()) if rest else None


def _syntax_error(text: str, exc: UnexpectedInput) -> RuleSyntaxError:
    if isinstance(exc, UnexpectedCharacters):
        pos = (exc.line, exc.column)
        char = text[exc.pos_in_stream] if exc.pos_in_stream < len(text) else ""
        hint = f"; expected {_expected(exc.allowed)}" if exc.allowed else ""
        return located(f"unexpected character {char!r}{hint}", pos)
    if isinstance(exc, UnexpectedToken):
        token = exc.token
        expected = exc.expected
        if token.type == "$END":
            pos = _end_pos(text)
            if "RBRACE" in expected or "RPAR" in expected:
                closing = "'}'" if "RBRACE" in expected else "')'"
                return located(f"unbalanced braces: missing {closing} at the end", pos)
            return located(f"unexpected end of the condition; expected {_expected(expected)}", pos)
        pos = token_pos(token)
        glued = _glued_number(text, token)
        if glued is not None:
            word, back = glued
            return located(f"{word!r} is not a number", (pos[0], pos[1] - back))
        if token.type == "RBRACE":
            return located(
                f"unbalanced braces: unexpected '}}'; expected {_expected(expected)}", pos
            )
        if token.type == "MORETHAN" and "OPERATOR" in expected:
            return located("a comparison is written OP>, OP< or OP= ('>' is member access)", pos)
        if token.type == "LBRACE" and "BANG" in expected:
            return located("expected ',' or '!' between clauses, got '{'", pos)
        if token.type == "LBRACE" and "RBRACE" in expected:
            return located("unbalanced braces: '{' inside a clause (missing '}'?)", pos)
        return located(f"unexpected {str(token)!r}; expected {_expected(expected)}", pos)
    pos = (getattr(exc, "line", 1) or 1, getattr(exc, "column", 1) or 1)
    return located(f"cannot parse the condition: {exc}", pos)


def parse_condition(text: str) -> ConditionAst:
    """The typed AST of ``text`` (shapes checked; functions and fields are checked by compile)."""
    if not text.strip():
        raise located("empty condition (write {TRUE} or '! {TRUE}' for one always true)", (1, 1))
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
