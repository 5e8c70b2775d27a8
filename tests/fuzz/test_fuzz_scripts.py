"""Generated and mutated scripts and conditions through ``oimi check`` and ``oimi compile``.

The valid scripts and conditions come from the property tests' strategies
(``tests/pipeline/script/test_script_properties.py``,
``tests/pipeline/think/test_conditions_parse.py``); they are then damaged: characters
deleted, inserted or replaced by the DSL's own punctuation, cut, deeply nested, or
stretched to a huge word. Every run ends with exit 0 or 2, a located message on 2 and
never a traceback or a hang.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import pytest
from hypothesis import given
from hypothesis import strategies as st
from oimi.pipeline.script import render_dsl

from .fuzzing import assert_clean_outcome, fuzz_settings, run_cli

TESTS = Path(__file__).resolve().parents[1]


def _strategies(relative: str) -> ModuleType:
    """A property-test module, loaded for its strategies (its tests are not collected)."""
    path = TESTS / relative
    spec = importlib.util.spec_from_file_location(f"fuzz_strategies_{path.stem}", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_SCRIPTS = _strategies("pipeline/script/test_script_properties.py")
_CONDITIONS = _strategies("pipeline/think/test_conditions_parse.py")

PIECES = st.sampled_from(
    ["[", "]", "(", ")", '"', "%", "#", ":", ",", "\n", "CND(", "b##", "blk_jump", "MV(", "\\"]
)


@st.composite
def damaged(draw: st.DrawFn, text: str) -> str:
    """``text`` with a few edits: a cut, deletions, insertions, deep nesting or a huge word."""
    for _ in range(draw(st.integers(1, 4))):
        at = draw(st.integers(0, len(text)))
        edit = draw(st.sampled_from(["insert", "delete", "replace", "cut", "nest", "huge"]))
        if edit == "insert":
            text = text[:at] + draw(PIECES | st.text(max_size=3)) + text[at:]
        elif edit == "delete":
            text = text[:at] + text[at + draw(st.integers(1, 8)) :]
        elif edit == "replace":
            text = text[:at] + draw(PIECES) + text[at + 1 :]
        elif edit == "cut":
            text = text[:at]
        elif edit == "nest":
            depth = draw(st.sampled_from([2, 63, 64, 65, 500, 5000]))
            text = text[:at] + "(" * depth + text[at:] + ")" * draw(st.sampled_from([0, depth]))
        else:
            text = text[:at] + draw(st.sampled_from('x(["')) * 20_000 + text[at:]
    return text


@pytest.fixture(scope="module")
def script_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz_scripts") / "generated.txt"


@fuzz_settings(60)
@given(data=st.data())
def test_damaged_scripts_are_checked_and_compiled_with_a_located_exit(
    script_file: Path, data: st.DataObject
) -> None:
    text = data.draw(damaged(render_dsl(data.draw(_SCRIPTS.scripts()))))
    script_file.write_bytes(text.encode("utf-8", errors="surrogatepass"))
    for command in (["check", str(script_file)], ["compile", str(script_file)]):
        code, _, err = run_cli(command)
        assert code in (0, 2), err
        assert_clean_outcome(code, err, located=f"{script_file}:")


@fuzz_settings(20)
@given(data=st.binary(max_size=200))
def test_any_bytes_as_a_script_end_with_a_located_exit(script_file: Path, data: bytes) -> None:
    script_file.write_bytes(data)
    code, _, err = run_cli(["check", str(script_file)])
    assert code in (0, 2), err
    assert_clean_outcome(code, err, located=f"{script_file}:")


@fuzz_settings(80)
@given(
    text=_CONDITIONS.valid_conditions().flatmap(damaged)
    | st.lists(_CONDITIONS._pieces, max_size=30).map("".join)
)
def test_damaged_conditions_are_checked_with_a_located_exit(text: str) -> None:
    code, _, err = run_cli(["check", "--condition", text])
    assert code in (0, 2), err
    assert_clean_outcome(code, err, located="<condition 1>:")
    assert len(err) < 2_000  # a window, never the whole condition
