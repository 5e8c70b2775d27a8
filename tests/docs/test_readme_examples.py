"""The README's language examples are real: every fenced dsl/condition block compiles."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from oimi.pipeline.messages import Human, WorldMap
from oimi.pipeline.script.dsl import compile_dsl
from oimi.pipeline.think.conditions import compile_condition

README = Path(__file__).resolve().parents[2] / "README.md"


def blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", README.read_text(), flags=re.S)


def test_the_readme_has_examples_of_both_languages() -> None:
    assert len(blocks("dsl")) >= 1 and len(blocks("condition")) >= 3


@pytest.mark.parametrize("text", blocks("dsl"))
def test_readme_scripts_compile(text: str) -> None:
    script = compile_dsl(text, source="README.md")
    assert script.goals


@pytest.mark.parametrize("text", blocks("condition"))
def test_readme_conditions_compile(text: str) -> None:
    compile_condition(text.strip())


def test_the_readme_reading_of_the_first_condition_holds_on_a_map() -> None:
    condition = compile_condition(blocks("condition")[0].strip())
    child = Human(id="c1", creationtime=0, positionrho=1.0, positiontheta=2.5)
    found = condition.evaluate(WorldMap(humans=[child]), now_ms=10_000)
    assert not found.result, "not in front: no alias, so false"
    child.positiontheta, child.positionchangetime = 0.0, 0
    found = condition.evaluate(WorldMap(humans=[child]), now_ms=10_000)
    assert found.bindings.get("?child") == "Human/c1"
