"""render_dsl: readable DSL with generated labels, refusals for unwritable conditions, and the
channel registry read by the DSL, the JSON format and the renderer."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from oimi.pipeline.messages import (
    CHANNELS,
    Action,
    AudioOut,
    Goal,
    InstructionBlock,
    JumpBlock,
    Led,
    Move,
    Script,
    TerminusBlock,
)
from oimi.pipeline.script import (
    ScriptError,
    compile_dsl,
    dump_script_json,
    load_script_json,
    render_dsl,
)

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


def test_every_channel_of_the_registry_is_written_read_and_rendered_in_its_order():
    """The DSL's item lists, the JSON's keys and the renderer follow ``CHANNELS``: each
    channel's keyword in order, each item's values in its Struct's field order, and a
    track path holding commas (a leading text value) survives both ways."""
    block = InstructionBlock(
        move=(Move(v_x=0.25, v_y=0.0, v_theta=-1.5, wait_t=0, duration=500),),
        led=(Led(r=1.0, g=0.5, b=0.0, turnas=1, wait_t=10, duration=20),),
        audioout=(AudioOut(track_path="songs/a, b.wav", wait_t=5, duration=1500),),
    )
    script = one_block(block)
    text = render_dsl(script)
    keywords = [line.strip().split("(")[0] for line in text.splitlines() if line[:4] == "    "]
    assert keywords == [spec.dsl for spec in CHANNELS]
    assert '    AO("songs/a, b.wav, 5, 1500")]' in text
    assert compile_dsl(text, source="r") == script
    item_json = json.loads(dump_script_json(script))["goal0"]["act0"]["blk0"]
    assert [k for k in item_json if k != "type"] == [spec.field for spec in CHANNELS]
    for spec in CHANNELS:
        names = [name for name, _ in spec.item_fields()]
        assert [list(item) for item in item_json[spec.field]] == [names]
    assert load_script_json(dump_script_json(script).encode(), source="j") == script


def test_a_blk_inst_without_its_channel_lists_names_them_from_the_registry():
    lists = " ".join(f"{spec.dsl}(...)" for spec in CHANNELS)
    with pytest.raises(ScriptError, match=re.escape(f"blk_inst needs {lists}, in this order")):
        compile_dsl('[a]\n[goal:g]\n[action]\n[b##blk_inst: LD("1, 0, 0, 1, 0, 5")]\n', source="r")
