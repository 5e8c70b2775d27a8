"""Every ```dsl example in the language reference compiles."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from oimi.pipeline.script import compile_dsl, validate_script

DOC = Path(__file__).parents[3] / "docs" / "script-language.md"
EXAMPLES = re.findall(r"^```dsl\n(.*?)^```", DOC.read_text(encoding="utf-8"), re.M | re.S)


def test_the_reference_has_dsl_examples():
    assert len(EXAMPLES) >= 3


@pytest.mark.parametrize("example", EXAMPLES, ids=[f"example{i}" for i in range(len(EXAMPLES))])
def test_dsl_example_in_the_docs_compiles(example):
    script = compile_dsl(example, source=str(DOC))
    validate_script(script, source=str(DOC))


@pytest.mark.parametrize("example", EXAMPLES, ids=[f"example{i}" for i in range(len(EXAMPLES))])
def test_jump_conditions_in_the_docs_compile(example):
    from oimi.pipeline.script import condition_errors, parse_dsl
    from oimi.pipeline.think.conditions import compile_condition

    parsed = parse_dsl(example, source=str(DOC))
    assert [str(e) for e in condition_errors(parsed, compile_condition)] == []
