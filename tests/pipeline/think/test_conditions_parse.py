"""Parsing and load-time checking of rule conditions (thesis section 4.3)."""

from __future__ import annotations

import re
from importlib import resources

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from oimi.pipeline.think.condition_ast import (
    PUNCTUATION,
    ClassClause,
    Comparison,
    EvalClause,
    TrueClause,
)
from oimi.pipeline.think.conditions import Condition, Op, Scope, compile_condition, parse_condition
from oimi.pipeline.think.errors import RuleSyntaxError
from oimi.pipeline.think.functions import FunctionRegistry
from oimi.pipeline.think.stdlib import default_registry

THESIS_EXAMPLE = (
    "{CLASS #Human U ?child ?THIS>&positionrho OP< 1.5, B: infront ()}"
    " ! {E: attention_low (?child)}"
)


def test_thesis_jump_condition_compiles():
    assert isinstance(compile_condition("! {TRUE}"), Condition)


def test_task_example_parses_into_typed_clauses():
    ast = parse_condition(THESIS_EXAMPLE)
    (clause,) = ast.left
    assert isinstance(clause, ClassClause)
    assert (clause.cls, clause.scope, clause.alias) == ("Human", Scope.U, "?child")
    comparison, call = clause.criteria
    assert isinstance(comparison, Comparison)
    assert comparison.op is Op.LT
    assert comparison.right.value == 1.5
    assert call.name == "infront"
    (evaluation,) = ast.right
    assert isinstance(evaluation, EvalClause)
    assert evaluation.call.args[0].alias == "?child"


@pytest.mark.parametrize(
    "text",
    [
        "! {TRUE}",
        "!{TRUE}",
        "! { TRUE }",
        "  !\n{\tTRUE\t}  ",
        "{TRUE}",
        "{ TRUE }",
        "! {E: joystick_engaged ()}",
        "!{E:joystick_engaged()}",
        "{CLASS #Human U ?c} !",
        "{CLASS #Human U ?c}!{TRUE}",
        "{CLASS#Human U?c?THIS>&positionrho OP<1.5,B:infront()}!{E:near(?c,1)}",
        "{ CLASS #Human U ?c ?THIS > &positionrho OP< 1.5 , B: infront ( ) }"
        " ! { E: near ( ?c , 1 ) }",
        '{VAR @v T F: concat ("a", "b")}, {TRUE} ! {E: var_is (@v, "ab")}',
        "{CLASS #Human U ?c}, {ATT ?c $d L F: distance (?c)} ! {E: equals (?c>$d, 1)}",
        '{CLASS #Object L ?o ?THIS>&category OP= "ball", ?THIS>&istarget OP= "true"} !',
        '{CLASS #Activity L ?a ?THIS>&status OP= "running"} ! {TRUE}, {E: near (?x, 1)}',
        "{CLASS #Obstacle T ?w ?THIS>&isfixed OP= 1, ?THIS>&positionrho OP> -0.5e1} !",
        "{CLASS #Human U ?a}, {CLASS #Human U ?b ?THIS>&positionrho OP> ?a>&positionrho} !",
        '! {E: touched ("C")}, {E: battery_below (1000)}, {E: goal_is ("g", "reached")}',
    ],
)
def test_valid_conditions_compile_whatever_the_spacing(text):
    assert compile_condition(text).text == text


def test_whitespace_does_not_change_the_tree():
    tight = parse_condition("{CLASS#Human U?c?THIS>&positionrho OP<1.5,B:infront()}!{TRUE}")
    loose = parse_condition(
        "{ CLASS #Human U ?c ?THIS > &positionrho OP< 1.5 , B: infront ( ) } ! { TRUE }"
    )
    strip = re.compile(r"pos=\(\d+, \d+\)|\w+_pos=\(\d+, \d+\)|bang_pos=.*|end_pos=.*")
    assert strip.sub("", repr(tight.left)) == strip.sub("", repr(loose.left))
    assert isinstance(tight.right[0], TrueClause) and isinstance(loose.right[0], TrueClause)


# One table of malformed conditions: (text, message fragment, column).
MALFORMED = [
    ("", "empty condition", 1),
    ("   ", "empty condition", 1),
    ("! {E: frobnicate ()}", "unknown function 'frobnicate'", 7),
    ("! {E: nearr (?c, 1)}", "did you mean 'near'", 7),
    ("! {E: infront ()}", "'infront' is a B: function, not E:", 7),
    ("{CLASS #Human U ?c B: near (?c, 1)} !", "'near' is a E: function, not B:", 23),
    ("{CLASS #Human U ?c E: near (?c, 1)} !", "a CLASS criterion takes a B: function, not E:", 20),
    ("{VAR @v U E: now ()} !", "a VAR or ATT clause takes an F: function, not E:", 11),
    ("! {B: infront ()}", "an evaluation clause takes an E: function, not B:", 4),
    ("! {E: near (?c)}", "'near' takes 2 argument(s), got 1", 7),
    ("! {E: joystick_engaged (1)}", "'joystick_engaged' takes 0 argument(s), got 1", 7),
    ("! {E: near (1, 2)}", "expected an alias (?name) here", 13),
    ('! {E: near (?c, "far")}', "expected a number here", 17),
    ("{CLASS #Robot U ?c} ! {TRUE}", "unknown class '#Robot'", 8),
    ("{CLASS #Humen U ?c} ! {TRUE}", "#Activity); did you mean #Human?", 8),
    ("! {E: near (?c, 1.0x)}", "'1.0x' is not a number", 17),
    ("! {E: near (?c, 1.0.5)}", "'1.0.5' is not a number", 17),
    ("{CLASS #Human U ?c ?THIS>&positionrho OP< -2e3q} !", "'-2e3q' is not a number", 43),
    ("{CLASS #Human U ?c ?THIS>&height OP> 1} !", "unknown field '&height' of #Human", 20),
    ("{CLASS #Human U ?c ?THIS>&positionrho OP! 1} !", "unknown operator 'OP!'", 39),
    ("{CLASS #Human U ?c ?THIS>&positionrho OP 1} !", "unknown operator 'OP'", 39),
    ("{CLASS #Human U ?c ?THIS>&positionrho > 1} !", "a comparison is written OP>, OP< or OP=", 39),
    ("{CLASS #Human U ?c}", "missing '!'", 20),
    ("{CLASS #Human U ?c} {E: near (?c, 1)}", "expected ',' or '!' between clauses", 21),
    ("{CLASS #Human U ?c}, {E: near (?c, 1)}", "missing '!'", 22),
    ("{CLASS #Human U ?c ! {TRUE}", "unexpected '!'", 20),
    ("! {TRUE", "unbalanced braces: missing '}'", 8),
    ("! {TRUE}}", "unbalanced braces: unexpected '}'", 9),
    ("! {{TRUE}}", "unexpected '{'", 4),
    ("{CLASS #Human U ?my/child} !", "bad alias name '?my/child'", 17),
    ("{CLASS #Human U ?} !", "bad alias name '?'", 17),
    ("{CLASS #Human U ?THIS} !", "?THIS names the entity under test", 17),
    ("! {E: near (?THIS, 1)}", "?THIS can only be used inside a CLASS clause", 13),
    ("{CLASS #Human X ?c} !", "bad scope 'X' (expected U, T or L)", 15),
    ("{CLASS #Human Up ?c} !", "bad scope 'Up'", 15),
    ("{VAR @a/b U F: now ()} !", "bad variable name '@a/b'", 6),
    ("{ATT ?c $ L F: now ()} !", "bad attribute name '$'", 9),
    ("! {X: near (?c, 1)}", "unknown function family 'X:'", 4),
    ("! {TRUE} %", "unexpected character '%'", 10),
    ("garbage", "unexpected 'garbage'; expected '!' or '{'", 1),
    ("! {E: near (?c, 1)} {TRUE}", "expected ',' or '!' between clauses", 21),
    ("{E: near (?c, 1)} ! {TRUE}", "E: evaluations belong after '!'", 1),
    ("! {CLASS #Human U ?c}", "assignments (CLASS, VAR, ATT) belong before '!'", 3),
    ("{TRUE} ! {TRUE} ! {TRUE}", "unexpected '!'", 17),
    ("{CLASS #Human U ?c ?THIS>&positionrho OP= ?d} !", "not a bare alias", 43),
    ("{CLASS #Human U ?c ?d>&positionrho OP= 1} !", "left of a comparison must be ?THIS", 20),
    ("{CLASS #Human U ?c B: is_target ()} !", "'is_target' does not apply to #Human", 23),
    ("{CLASS #Human U ?c ?THIS>&positionrho OP= ?d>&colour} !", "unknown field '&colour'", 43),
    ("! {E: near (?c, 1)}\n, {E: far (?c, 2}", "unexpected '}'", 17),
    ('! {E: var_is (@v, "a\\q")}', "bad string literal", 19),
]


@pytest.mark.parametrize(("text", "fragment", "column"), MALFORMED)
def test_malformed_condition_is_reported_with_its_column(text, fragment, column):
    with pytest.raises(RuleSyntaxError, match=re.escape(fragment)) as info:
        compile_condition(text)
    assert info.value.column == column
    assert info.value.source == "<condition>"
    assert str(info.value).startswith(f"<condition>:{info.value.line}:{column}: ")


def test_error_on_a_later_line_names_that_line():
    with pytest.raises(RuleSyntaxError) as info:
        compile_condition("{CLASS #Human U ?c}\n  !\n  {E: neer (?c, 1)}")
    assert (info.value.line, info.value.column) == (3, 7)
    assert str(info.value) == "<condition>:3:7: unknown function 'neer'; did you mean 'near'?"


def test_error_can_be_placed_inside_a_script_file():
    with pytest.raises(RuleSyntaxError) as info:
        compile_condition("! {E: nope ()}")
    placed = info.value.located("script.txt", line_offset=12, column_offset=10)
    assert str(placed).startswith("script.txt:13:17: unknown function 'nope'")


# ----------------------------------------------------------------------- properties

_alias = st.sampled_from(["?child", "?c2", "?_x", "?ball"])
_number = st.integers(-1000, 1000).map(str) | st.floats(-10, 10, allow_nan=False).map(
    lambda f: f"{f:.3f}"
)
_string = st.text(alphabet="abc xyz", max_size=5).map(lambda s: f'"{s}"')
_literal = _number | _string
_field = st.sampled_from(["positionrho", "positiontheta", "id", "creationtime"])
_operator = st.sampled_from(["OP=", "OP<", "OP>"])
_space = st.sampled_from(["", " ", "  ", "\n", "\t"])


@st.composite
def _criterion(draw):
    if draw(st.booleans()):
        value = draw(_literal | _alias.map(lambda a: f"{a}>&positionrho") | st.just("@v"))
        return f"?THIS>&{draw(_field)} {draw(_space)}{draw(_operator)}{draw(_space)}{value}"
    return draw(
        st.sampled_from(
            ["B: infront ()", "B: infront (0.3)", "B: closer_than (2)", 'B: has_attribute ("x")']
        )
    )


@st.composite
def _left_clause(draw):
    kind = draw(st.sampled_from(["class", "var", "att", "true"]))
    sp = draw(_space)
    if kind == "class":
        criteria = draw(st.lists(_criterion(), max_size=3))
        cls = draw(st.sampled_from(["Human", "Obstacle", "Object"]))
        scope = draw(st.sampled_from("UTL"))
        return f"{{CLASS #{cls} {scope} {draw(_alias)} {sp}{', '.join(criteria)}}}"
    if kind == "var":
        return f'{{VAR @v {draw(st.sampled_from("UTL"))} F: concat ({draw(_string)}, "x")}}'
    if kind == "att":
        return f"{{ATT {draw(_alias)} $a {sp}L F: distance ({draw(_alias)})}}"
    return f"{{{sp}TRUE{sp}}}"


@st.composite
def _right_clause(draw):
    return draw(
        st.sampled_from(
            [
                "{E: near (?child, 1.5)}",
                "{E: attention_low (?c2)}",
                '{E: touched ("C", 500)}',
                "{E: no_human_in_front ()}",
                '{E: var_is (@v, "a")}',
                "{ TRUE }",
                "{E: equals (?ball>$a, ?child>&id)}",
            ]
        )
    )


@st.composite
def valid_conditions(draw):
    left = draw(st.lists(_left_clause(), max_size=3))
    right = draw(st.lists(_right_clause(), max_size=3))
    sp = draw(_space)
    return f"{sp}{(',' + sp).join(left)}{sp}!{sp}{(',' + sp).join(right)}{sp}"


@settings(max_examples=80, deadline=None)
@given(valid_conditions())
def test_generated_valid_conditions_always_compile(text):
    compile_condition(text)


_pieces = st.sampled_from(
    ["{", "}", "!", ",", "(", ")", "CLASS", "#Human", "U", "?c", "?THIS>&positionrho", "OP<",
     "1", '"x"', "B:", "E:", "F:", "VAR", "@v", "ATT", "$a", "TRUE", "near", " ", ">", "&", "OP"]
)  # fmt: skip


@settings(max_examples=100, deadline=None)
@given(st.text(max_size=40) | st.lists(_pieces, max_size=15).map("".join))
def test_random_text_only_ever_raises_rule_syntax_error(text):
    try:
        compile_condition(text)
    except RuleSyntaxError as error:
        assert error.line >= 1 and error.column >= 1


def test_the_grammar_ends_a_designers_name_at_the_punctuation_the_parser_names() -> None:
    """``condition.lark`` lexes ``?``/``@``/``$`` names up to the same characters that
    ``condition_ast.PUNCTUATION`` lists (and its errors name)."""
    grammar = resources.files("oimi.pipeline.think").joinpath("condition.lark").read_text()
    for sigil in ("\\?", "@", "\\$"):
        assert f"/{sigil}[^\\s{PUNCTUATION}]*/" in grammar, sigil


def test_a_text_is_compiled_once_per_registry() -> None:
    """A script's alfa messages create its rules again at each load: their conditions are
    found compiled (a condition holds no state of its own), per function registry."""
    first = compile_condition(THESIS_EXAMPLE)
    assert compile_condition(THESIS_EXAMPLE, registry=default_registry()) is first
    other = FunctionRegistry(default_registry().functions())
    assert compile_condition(THESIS_EXAMPLE, registry=other) is not first
