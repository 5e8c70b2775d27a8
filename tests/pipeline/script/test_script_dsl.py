"""The DSL compiler: every construct, the thesis's examples, and every error with line:col."""

from __future__ import annotations

from pathlib import Path

import pytest
from oimi.pipeline.messages import (
    AudioOut,
    InstructionBlock,
    JumpBlock,
    Led,
    Move,
    MutexCmd,
    RuleAction,
    SensorBlock,
    TerminusBlock,
)
from oimi.pipeline.script import ScriptError, compile_dsl, load_script_json

FIXTURES = Path(__file__).with_name("fixtures")
ACTIVITIES = Path(__file__).parents[3] / "scenarios" / "library" / "activities"

GARBLED_EXAMPLE = """\
[example_act]
[alfa:16,my_rule,"\\\\myinputtopic","\\\\myoutputtopic",A,M]
[alfa:o,kick_starter,"","",R,U]
[omega:o,kick_starter,"","",C,L]
[goal:blinking_and_stop]
[action]
[b##blk_inst: MV() LD("o, o, 1, 1, o, 100", "o, o, 1, 1, o, 100") AO()]
"""
CORRECTED_EXAMPLE = GARBLED_EXAMPLE.replace("o,", "0,").replace("o, 1", "0, 1")
HEAD = "[a]\n[goal:g]\n[action]\n"


def compile_text(text: str):
    return compile_dsl(text, source="f.txt")


def blocks_of(text: str):
    return compile_text(HEAD + text).goals[0].actions[0].blocks


def test_corrected_thesis_example_compiles():
    script = compile_text(CORRECTED_EXAMPLE)
    assert script.activityname == "example_act"
    first, second = script.alfarulemessages
    assert (first.rulecode, first.id, first.intopic, first.outtopic) == (
        16,
        "my_rule",
        "\\myinputtopic",
        "\\myoutputtopic",
    )
    assert (first.action, first.mutexcmd) == (RuleAction.A, MutexCmd.M)
    assert (second.id, second.action, second.mutexcmd) == ("kick_starter", RuleAction.R, MutexCmd.U)
    assert script.omegarulemessages[0].action is RuleAction.C
    assert script.goals[0].goalid == "blinking_and_stop"
    (block,) = script.goals[0].actions[0].blocks
    blue = Led(r=0, g=0, b=1, turnas=1, wait_t=0, duration=100)
    assert block == InstructionBlock(led=(blue, blue))


def test_printed_example_hints_that_o_means_0():
    with pytest.raises(
        ScriptError,
        match=r"^f\.txt:3:7: rulecode: 'o' is not a number; did you "
        r"mean 0\?",
    ):
        compile_text(GARBLED_EXAMPLE)


def test_o_inside_an_item_string_gets_the_hint_at_its_column():
    with pytest.raises(ScriptError, match=r"^f\.txt:4:24: 'o' is not a number; did you mean 0\?"):
        blocks_of('[b##blk_inst: MV() LD("o, 0, 1, 1, 0, 100") AO()]')


def test_instruction_block_reads_moves_leds_and_audio():
    (block,) = blocks_of(
        '[b#x#blk_inst: MV("0.05, -0.01, 0.2, 100, 1000", "1e-2, 0, 0, 0, 0")\n'
        ' LD("1, 0.5, 0, 0, 0, 2000") AO("songs/a, b.wav, 5, 4000") FLG("flag")]'
    )
    assert block == InstructionBlock(
        move=(
            Move(v_x=0.05, v_y=-0.01, v_theta=0.2, wait_t=100, duration=1000),
            Move(v_x=0.01, v_y=0, v_theta=0, wait_t=0, duration=0),
        ),
        led=(Led(r=1, g=0.5, b=0, turnas=0, wait_t=0, duration=2000),),
        audioout=(AudioOut(track_path="songs/a, b.wav", wait_t=5, duration=4000),),
        flagged="flag",
    )


def test_instruction_block_without_flag_has_none_and_colon_is_optional():
    (block,) = blocks_of("[b##blk_inst MV() LD() AO()]")
    assert block == InstructionBlock()
    assert block.flagged is None


def test_jump_condition_is_taken_verbatim_with_nested_parentheses_and_braces():
    blocks = blocks_of(
        '[b#top#blk_jump:CND(! {E: near (?child, "1.5)")})TRJMP(end)FLSJMP()]\n[b#end#blk_terminus]'
    )
    assert blocks[0] == JumpBlock(
        toparse='! {E: near (?child, "1.5)")}', truejump="goal0/act0/blk1", falsejump=""
    )


def test_labels_resolve_across_goals_and_actions():
    script = compile_text(
        "[a]\n[goal:one]\n[action]\n[b#start#blk_terminus]\n[action]\n[b##blk_terminus]\n"
        "[goal:two]\n[action]\n[b##blk_terminus]\n[b#back#blk_jump: CND(! {TRUE}) "
        "TRJMP(start) FLSJMP(back)]"
    )
    jump = script.goals[1].actions[0].blocks[1]
    assert (jump.truejump, jump.falsejump) == ("goal0/act0/blk0", "goal1/act0/blk1")
    assert [len(g.actions) for g in script.goals] == [2, 1]


def test_terminus_and_sensor_blocks():
    blocks = blocks_of(
        "[b##blk_terminus][b##blk_sensor][b##blk_sens][b##blk_sens: To Be Defined (later)]"
        '[b##blk_sensor: "camera, front"]'
    )
    assert blocks == (
        TerminusBlock(),
        SensorBlock(),
        SensorBlock(),
        SensorBlock(request="To Be Defined (later)"),
        SensorBlock(request="camera, front"),
    )


def test_comments_and_whitespace_are_ignored_between_and_inside_items():
    script = compile_text(
        "% a script %\n[ a ] % name %\n[goal: g]%x%[action]\n"
        "[b##blk_inst:\n  MV() % no move %\n  LD()\n  AO()]\n% end %"
    )
    assert script.goals[0].goalid == "g"


def test_quoted_names_and_empty_fields():
    script = compile_text(
        '["my act"]\n[alfa:3,"a rule",,"",D,U]\n[goal:"goal one"]\n[action]\n[b##blk_terminus]'
    )
    assert script.activityname == "my act"
    assert script.alfarulemessages[0].id == "a rule"
    assert script.alfarulemessages[0].intopic == ""
    assert script.goals[0].goalid == "goal one"


def test_test_act_txt_compiles_to_listing_4_1():
    listing = load_script_json((FIXTURES / "listing_4_1.json").read_bytes(), source="l.json")
    compiled = compile_dsl(
        (ACTIVITIES / "test_act.txt").read_text(encoding="utf-8"), source="test_act.txt"
    )
    assert compiled == listing


# (message regex without the "f.txt:" prefix, bad inputs): one table, looped over below.
ERROR_TABLE: list[tuple[str, list[str]]] = [
    (r"1:1: empty script: expected its name first", ["", "  \n", "% only a comment %"]),
    (r"1:1: missing \[activityname\]", ['[alfa:0,k,"","",R,U]\n[goal:g]', "[goal:g]"]),
    (r"2:1: \[action\] before any \[goal:\.\.\.\]", ["[a]\n[action]"]),
    (r"2:1: block before any \[goal:\.\.\.\] and \[action\]", ["[a]\n[b##blk_terminus]"]),
    (r"3:1: block before any \[action\] of goal 'g'", ["[a]\n[goal:g]\n[b##blk_terminus]"]),
    (
        r"5:4: duplicate label 'x' \(first used at line 4, column 4\)",
        [HEAD + "[b#x#blk_terminus]\n[b#x#blk_terminus]"],
    ),
    (
        r"4:33: jump to unknown label 'nowhere'; did you mean 'somewhere'\?",
        [HEAD + "[b##blk_jump:CND(! {TRUE})TRJMP(nowhere)FLSJMP()]\n[b#somewhere#blk_terminus]"],
    ),
    (r"4:25: 'x' is not a number$", [HEAD + '[b##blk_inst: MV("1, 2, x, 0, 0") LD() AO()]']),
    (
        r"4:31: duration must be a whole number, got 1\.5",
        [HEAD + '[b##blk_inst: MV("1, 2, 0, 0, 1.5") LD() AO()]'],
    ),
    (
        r"4:18: a move needs 5 values \"v_x, v_y, v_theta, wait_t, duration\", got 4",
        [HEAD + '[b##blk_inst: MV("1, 2, 0, 0") LD() AO()]'],
    ),
    (
        r"4:27: goal0/act0/blk0\.led\[0\]\.g: colour g must be between 0 and 1, got 2",
        [HEAD + '[b##blk_inst: MV() LD("1, 2, 0, 1, 0, 0") AO()]'],
    ),
    (
        r"2:19: alfarulemessages\[0\]\.mutexcmd: mutexcmd must be U here, got M",
        ['[a]\n[alfa:0,k,"","",R,M]\n[goal:g]\n[action]\n[b##blk_terminus]'],
    ),
    (
        r"2:20: omegarulemessages\[0\]\.mutexcmd: mutexcmd must be L here, got U",
        ['[a]\n[omega:0,k,"","",R,U]\n[goal:g]\n[action]\n[b##blk_terminus]'],
    ),
    (r"2:17: action must be one of A, R, D, B, C, got 'X'", ['[a]\n[alfa:0,k,"","",X,U]']),
    (r"2:1: \[alfa:\.\.\.\] needs 6 fields", ['[a]\n[alfa:0,k,"",R,U]']),
    (
        r"3:1: \[alfa:\.\.\.\] after \[omega:\.\.\.\]",
        ['[a]\n[omega:0,k,"","",R,L]\n[alfa:0,k,"","",C,U]'],
    ),
    (r"4:1: \[omega:\.\.\.\] after a goal", [HEAD + '[omega:0,k,"","",R,L]']),
    (r"4:5: unknown block type 'blk_foo'; expected blk_inst", [HEAD + "[b##blk_foo]"]),
    (r"4:6: unknown block type 'blk_foo'", [HEAD + "[b#x#blk_foo]"]),
    (
        r"4:6: unknown block type 'blk_insr'; expected blk_inst, .* or blk_sensor; did you mean "
        r"blk_inst\?$",
        [HEAD + "[b#x#blk_insr: MV() LD() AO()]", HEAD + "[b#x#blk_insr MV() LD() AO()]"],
    ),
    (
        r"4:5: unknown block type 'blk_sensors'; expected .*; did you mean blk_sensor\?$",
        [HEAD + "[b##blk_sensors]"],
    ),
    (
        r"4:1: unknown item \[acton\]: the activity name was already given; did you mean "
        r"\[action\]\?",
        [HEAD + "[acton]"],
    ),
    (r"4:19: unexpected text 'stray' outside brackets", [HEAD + "[b##blk_terminus] stray"]),
    (
        r"4:1: unbalanced brackets: this '\[' is never closed",
        [HEAD + "[b##blk_terminus", HEAD + "[b##blk_jump:CND(! {TRUE})TRJMP()FLSJMP()"],
    ),
    (r"2:9: unbalanced brackets: '\]' missing before this '\['", ["[a]\n[goal:g [action]"]),
    (r"4:18: unbalanced brackets: this '\]' has no matching '\['", [HEAD + "[b##blk_terminus]]"]),
    (
        r"4:41: unbalanced parentheses: '\)' missing before this '\]'",
        [HEAD + "[b##blk_jump:CND(! (TRUE)TRJMP()FLSJMP()]"],
    ),
    (
        r"4:18: unbalanced parentheses: this '\)' has no matching '\('",
        [HEAD + "[b##blk_terminus])"],
    ),
    (
        r"4:34: unexpected 'LD'; expected '\)' or ','",
        [HEAD + '[b##blk_inst: MV("1, 2, 0, 0, 0" LD() AO()]'],
    ),
    (
        r"4:15: unexpected 'LD': blk_inst needs MV\(\.\.\.\) LD\(\.\.\.\) AO\(\.\.\.\)",
        [HEAD + "[b##blk_inst: LD() AO()]"],
    ),
    (
        r"4:14: unexpected 'TRJMP': blk_jump needs CND\(condition\) TRJMP\(label\)",
        [HEAD + "[b##blk_jump:TRJMP()FLSJMP()]"],
    ),
    (r"4:18: unterminated string", [HEAD + '[b##blk_inst: MV("1, 2, 0, 0) LD() AO()]']),
    (r"4:19: unterminated comment", [HEAD + "[b##blk_terminus] % unclosed"]),
    (
        r"4:6: unexpected 'b#blk_terminus': expected '#' after the label",
        [HEAD + "[b#a b#blk_terminus]"],
    ),
    (r"4:29: bad escape in track path", [HEAD + '[b##blk_inst: MV() LD() AO("x\\q, 0, 0")]']),
    (
        r"4:34: unexpected 'x'; expected a quoted string",
        [HEAD + "[b##blk_inst: MV() LD() AO() FLG(x)]"],
    ),
    (
        r"4:5: goal0/act0/blk0\.toparse: the jump has no condition",
        [HEAD + "[b##blk_jump:CND()TRJMP()FLSJMP()]"],
    ),
    (r"5:1: goal1: goal1 has no action", [HEAD + "[b##blk_terminus]\n[goal:x]"]),
    (r"1:2: activityname: the script has no goal", ["[lonely]"]),
    (r"1:4: bad escape in string \"a\\q\": Invalid \\escape", ['["a\\q"]']),
]


@pytest.mark.parametrize(
    ("message", "text"),
    [(message, text) for message, texts in ERROR_TABLE for text in texts],
)
def test_bad_input_gets_a_named_located_error(message, text):
    with pytest.raises(ScriptError, match=rf"^f\.txt:{message}"):
        compile_text(text)


def test_syntax_error_carries_a_caret_under_the_column():
    with pytest.raises(ScriptError) as caught:
        compile_text(HEAD + "[b##blk_foo]")
    assert caught.value.context == "[b##blk_foo]\n    ^"


def test_binary_text_is_rejected():
    with pytest.raises(ScriptError, match=r"^f\.txt:1:4: not a text script \(it contains NUL"):
        compile_text("[a]\x00")
