"""A bad jump condition is reported where its text sits in the file, escapes and lines included."""

from __future__ import annotations

import json

from oimi.pipeline.errors import LocatedError
from oimi.pipeline.script import condition_errors, parse_script

CONDITION = '! {E: near (?x, "1.5")}, {E: nosuch ()}'


def fail_at_nosuch(text: str) -> None:
    """Stands in for the rule compiler: rejects ``nosuch`` at its column (line 1)."""
    if "nosuch" in text:
        column = text.index("nosuch") + 1
        raise LocatedError("unknown function 'nosuch'", source="<condition>", line=1, column=column)


def errors_of(text: str, source: str) -> list[str]:
    parsed = parse_script(text, source=source)
    return [str(error) for error in condition_errors(parsed, fail_at_nosuch)]


def jump_json(condition: str) -> str:
    block = {"type": "jump", "toparse": condition, "truejump": "", "falsejump": ""}
    document = {"activityname": "a", "goal0": {"goalid": "g", "act0": {"blk0": block}}}
    return json.dumps(document)


def test_json_condition_error_counts_escapes_in_the_file():
    text = jump_json(CONDITION)
    expected_column = text.index("nosuch") + 1  # one line; \" takes two characters
    assert errors_of(text, "s.json") == [f"s.json:1:{expected_column}: unknown function 'nosuch'"]


def test_json_condition_error_after_a_unicode_escape():
    text = jump_json("! {E: f (\u00e9)}, {E: nosuch ()}").replace("\u00e9", "\\u00e9")
    assert "\\u00e9" in text
    expected_column = text.index("nosuch") + 1
    assert errors_of(text, "s.json") == [f"s.json:1:{expected_column}: unknown function 'nosuch'"]


def test_dsl_condition_error_on_a_continuation_line():
    text = (
        "[a]\n[goal:g]\n[action]\n"
        '[b##blk_jump: CND(! {E: near (?x, "1.5")},\n'
        "       {E: nosuch ()}) TRJMP() FLSJMP()]\n"
    )
    assert errors_of(text, "s.txt") == ["s.txt:5:12: unknown function 'nosuch'"]


def test_good_conditions_give_no_error():
    assert errors_of(jump_json("! {TRUE}"), "s.json") == []
