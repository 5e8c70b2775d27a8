"""Scripts made to be slow or loud: deep nesting is refused quickly at its place, and an
error on a huge line shows a window around the column, never the whole line."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from oimi.pipeline.script.dsl import MAX_NESTING
from oimi.pipeline.script.sourcemap import CONTEXT_CHARS

from oimi.cli import main

HEAD = "[a]\n[goal:g]\n[action]\n"
BIG = 200_000


def check(tmp_path: Path, text: str, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    script = tmp_path / "s.txt"
    script.write_text(text)
    code = main(["check", str(script)])
    return code, capsys.readouterr().err


def jump(condition: str) -> str:
    return f"{HEAD}[b##blk_jump: CND({condition}) TRJMP() FLSJMP()]\n[b##blk_terminus]\n"


def test_a_condition_nested_to_the_limit_parses_and_one_deeper_is_refused_at_its_paren(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    inside = "{TRUE}"  # the parentheses around it are not the condition language's
    code, err = check(tmp_path, jump("(" * MAX_NESTING + inside + ")" * MAX_NESTING), capsys)
    assert "nest deeper" not in err
    column = len("[b##blk_jump: CND(") + MAX_NESTING + 1
    code, err = check(tmp_path, jump("(" * (MAX_NESTING + 1) + ")" * (MAX_NESTING + 1)), capsys)
    assert code == 2
    assert err.startswith(f"{tmp_path / 's.txt'}:4:{column}: parentheses in CND(...) nest deeper")


def test_forty_thousand_levels_are_refused_at_the_limit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    depth = 40_000  # took 29 s to parse before the limit
    code, err = check(tmp_path, jump("(" * depth + "{TRUE}" + ")" * depth), capsys)
    assert code == 2
    assert f":4:{len('[b##blk_jump: CND(') + MAX_NESTING + 1}: parentheses in CND" in err


@pytest.mark.parametrize(
    ("text", "line", "column"),
    [
        (f"{HEAD}[b##blk_inst: MV() LD() AO() {'x' * BIG}]\n", 4, 30),
        (f'{HEAD}[b##blk_inst: MV("{"x" * BIG}") LD() AO() ]] ]\n', 4, BIG + 33),
        (f"[a{'x' * BIG}\n", 1, 1),
    ],
    ids=["word", "late", "unclosed"],
)
def test_an_error_on_a_huge_line_shows_a_window_around_its_column(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, line: int, column: int
) -> None:
    code, err = check(tmp_path, text, capsys)
    assert code == 2
    first, shown, caret = err.splitlines()[:3]
    assert first.startswith(f"{tmp_path / 's.txt'}:{line}:{column}: ")
    assert len(err) < 3 * CONTEXT_CHARS + 400
    assert len(shown.strip()) <= CONTEXT_CHARS + 2
    assert caret.endswith("^")
    assert shown[len(caret) - 1] == text.splitlines()[line - 1][column - 1]


def test_a_condition_error_quoting_a_huge_word_cuts_the_word(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["check", "--condition", "{CLASS #" + "x" * BIG + " u ?x}"]) == 2
    err = capsys.readouterr().err
    assert len(err) < 400
    assert re.search(r"unknown class '#x+…x+' \(expected", err), err
