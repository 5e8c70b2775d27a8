"""docs/extending.md is true: excerpts match the example's files, the rest runs or compiles."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest
from oimi.pipeline.think.conditions import compile_condition
from oimi.scenarios.extensions import build_toolkit, load_extension

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "extending.md"
EXTENSION = ROOT / "examples" / "bubbles" / "bubbles"


def blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", DOC.read_text(), flags=re.S)


def excerpts() -> list[tuple[str, str]]:
    """(file, text) of every block whose first line is a comment naming a file."""
    found = []
    for block in blocks("python") + blocks("toml"):
        first, _, rest = block.partition("\n")
        if first.startswith("# examples/"):
            found.append((first.removeprefix("# "), rest))
    return found


def test_the_page_has_excerpts_runnable_code_conditions_and_commands() -> None:
    assert len(excerpts()) >= 6
    assert len(blocks("condition")) >= 2 and len(blocks("sh")) == 1
    assert [b for b in blocks("python") if not b.startswith("# examples/")]


@pytest.mark.parametrize(("file", "text"), excerpts())
def test_an_excerpt_is_verbatim_from_its_file(file: str, text: str) -> None:
    assert text.strip() in (ROOT / file).read_text()


@pytest.mark.parametrize("text", blocks("condition"))
def test_the_conditions_compile_with_the_extension(text: str) -> None:
    functions = build_toolkit([load_extension(str(EXTENSION))]).registries.functions
    compile_condition(text.strip(), registry=functions)


@pytest.mark.parametrize("text", blocks("toml"))
def test_the_toml_blocks_are_toml(text: str) -> None:
    tomllib.loads(text)


def test_the_commands_name_files_that_exist() -> None:
    (commands,) = blocks("sh")
    for line in commands.splitlines():
        assert line.startswith("oimi ")
        for word in line.split():
            if word.startswith("examples/"):
                assert (ROOT / word).exists(), word


def test_the_notebook_block_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)
    for block in blocks("python"):
        if not block.startswith("# examples/"):
            exec(compile(block, str(DOC), "exec"), {})
