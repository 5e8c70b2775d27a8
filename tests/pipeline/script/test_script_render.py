"""render_dsl: readable DSL with generated labels, and refusals for unwritable conditions."""

from __future__ import annotations

from pathlib import Path

import pytest
from oimi.pipeline.messages import Action, Goal, JumpBlock, Script, TerminusBlock
from oimi.pipeline.script import ScriptError, compile_dsl, load_script_json, render_dsl

LISTING = Path(__file__).with_name("fixtures") / "listing_4_1.json"


def test_listing_renders_with_labels_only_where_jumps_land():
    text = render_dsl(load_script_json(LISTING.read_bytes(), source="l.json"))
    assert text.startswith('[test_act]\n[alfa:0, kick_starter, "", "", C, U]\n')
    assert "[b#g0a0b0#blk_inst:" in text
    assert "[b##blk_inst:" in text
    assert "[b##blk_jump: CND(! {TRUE}) TRJMP(g0a0b4) FLSJMP()]" in text
    assert text.rstrip().endswith("[b#g0a0b4#blk_terminus]")
    assert 'FLG("flag")' in text


def one_block(block) -> Script:
    return Script(
        activityname="action",
        goals=(Goal(goalid="a goal", actions=(Action(blocks=(block, TerminusBlock())),)),),
    )


def test_names_that_cannot_be_bare_are_quoted():
    text = render_dsl(one_block(TerminusBlock()))
    assert text.startswith('["action"]\n[goal:"a goal"]\n')
    assert compile_dsl(text, source="r") == one_block(TerminusBlock())


@pytest.mark.parametrize("condition", ["! {E: f (}", "! {E: f )(}", '! {E: f ("}', "! [x]"])
def test_condition_that_cannot_be_written_verbatim_is_refused(condition):
    with pytest.raises(ScriptError, match=r"goal0/act0/blk0\.toparse: the condition .* cannot be"):
        render_dsl(one_block(JumpBlock(toparse=condition)))
