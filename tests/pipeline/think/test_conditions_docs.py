"""docs/condition-language.md: its condition blocks compile and its examples hold."""

from __future__ import annotations

import json
import re
from pathlib import Path

import msgspec
import pytest
from oimi.pipeline.messages import WorldMap
from oimi.pipeline.think.conditions import compile_condition
from oimi.pipeline.think.stdlib import default_registry

DOC = Path(__file__).resolve().parents[3] / "docs" / "condition-language.md"
FENCE = re.compile(r"^```([^\n]*)\n(.*?)^```", re.MULTILINE | re.DOTALL)


def _blocks() -> list[tuple[str, str]]:
    return [(info.strip(), body) for info, body in FENCE.findall(DOC.read_text(encoding="utf-8"))]


def _conditions() -> list[str]:
    return [body.strip() for info, body in _blocks() if info == "condition"]


def _examples() -> list[tuple[str, dict]]:
    pairs, last = [], None
    for info, body in _blocks():
        if info == "condition":
            last = body.strip()
        elif info == "json example":
            assert last is not None, "a json example must follow a condition block"
            pairs.append((last, json.loads(body)))
    return pairs


def test_the_document_has_condition_blocks_and_examples():
    assert len(_conditions()) >= 10
    assert len(_examples()) >= 5


@pytest.mark.parametrize("text", _conditions())
def test_condition_block_compiles(text):
    compile_condition(text)


@pytest.mark.parametrize(("text", "example"), _examples())
def test_example_gives_the_documented_result(text, example):
    world = msgspec.convert(example["map"], WorldMap)
    outcome = compile_condition(text).evaluate(world, now_ms=example["now_ms"], tick_scope={})
    assert outcome.result is example["result"]
    assert outcome.bindings == example["bindings"]


def test_standard_library_table_lists_every_function():
    text = DOC.read_text(encoding="utf-8")
    table = text.split("## Standard library", 1)[1].split("###", 1)[0]
    listed = set(re.findall(r"^\| [BFE] \| `(\w+) \(", table, flags=re.MULTILINE))
    listed |= set(re.findall(r"/ `(\w+) \(", table))
    assert listed == set(default_registry().names())
