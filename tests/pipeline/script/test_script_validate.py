"""Validation: every rule, by path, with the JSON line:column of the offending key."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from oimi.pipeline.messages import (
    Action,
    Goal,
    InstructionBlock,
    JumpBlock,
    Led,
    Move,
    MutexCmd,
    RuleAction,
    RuleMessage,
    Script,
    TerminusBlock,
)
from oimi.pipeline.script import ScriptError, load_script_json, script_errors, validate_script

LISTING = (Path(__file__).with_name("fixtures") / "listing_4_1.json").read_text(encoding="utf-8")


def load(text: str):
    return load_script_json(text, source="s.json")


def replaced(old: str, new: str, count: int = 1) -> str:
    assert old in LISTING
    return LISTING.replace(old, new, count)


JSON_ERRORS = [
    # (old text, new text, expected message)
    (
        '"truejump": "goal0/act0/blk4"',
        '"truejump": "goal0/act0/blk9"',
        r"s\.json:164:9: goal0/act0/blk2\.truejump: jump to goal0/act0/blk9, which does not exist",
    ),
    (
        '"falsejump": ""',
        '"falsejump": "goal3/act0/blk0"',
        r"s\.json:165:9: goal0/act0/blk2\.falsejump: jump to goal3/act0/blk0",
    ),
    (
        '"truejump": "goal0/act0/blk0"',
        '"truejump": "blk0"',
        r"goal0/act0/blk3\.truejump: jump target 'blk0' is not a path goalX/actY/blkZ",
    ),
    (
        '"type": "terminus"',
        '"type": "halt"',
        r"s\.json:174:9: goal0/act0/blk4\.type: unknown block type 'halt'",
    ),
    (
        '"g": "1"',
        '"g": "1.5"',
        r"s\.json:84:9: goal0/act0/blk0\.led\[1\]\.g: colour g must be between 0 and 1, got 1\.5",
    ),
    (
        '"r": "1"',
        '"r": -0.1',
        r"goal0/act0/blk0\.led\[0\]\.r: colour r must be between 0 and 1, got -0\.1",
    ),
    (
        '"turnas": 1',
        '"turnas": 2',
        r"s\.json:78:9: goal0/act0/blk0\.led\[0\]\.turnas: turnas must be 0 \(off\) or 1 \(on\)",
    ),
    (
        '"wait_t": 1,',
        '"wait_t": -1,',
        r"s\.json:126:9: goal0/act0/blk0\.audioout\[0\]\.wait_t: wait_t must be a whole number",
    ),
    (
        '"duration": 4000',
        '"duration": 4000.5',
        r"goal0/act0/blk1\.audioout\[0\]\.duration: duration must be a whole number .* 4000\.5",
    ),
    (
        '"duration": 4000',
        '"duration": "1.5"',
        r"goal0/act0/blk1\.audioout\[0\]\.duration: duration must be a whole number, got '1\.5'",
    ),
    (
        '"mutexcmd": 85',
        '"mutexcmd": 77',
        r"s\.json:10:13: alfarulemessages\[0\]\.mutexcmd: mutexcmd must be U here, got M",
    ),
    (
        '"mutexcmd": 85',
        '"mutexcmd": 76',
        r"alfarulemessages\[0\]\.mutexcmd: mutexcmd must be U here, got L: alfa messages",
    ),
    (
        '"mutexcmd": 76',
        '"mutexcmd": 85',
        r"s\.json:20:13: omegarulemessages\[0\]\.mutexcmd: mutexcmd must be L here, got U: omega",
    ),
    (
        '"action": 67',
        '"action": 70',
        r"s\.json:9:14: alfarulemessages\[0\]\.action: action must be one of A \(65\), R \(82\), "
        r"D \(68\), B \(66\), C \(67\), got 70 \('F'\)",
    ),
    (
        '"mutexcmd": 85',
        '"mutexcmd": "X"',
        r"alfarulemessages\[0\]\.mutexcmd: mutexcmd must be one of L \(76\), M \(77\), U \(85\)",
    ),
    (
        '"blk3"',
        '"blk5"',
        r"s\.json:173:5: goal0/act0/blk4: blk4 without blk3: blk numbers must run 0, 1, 2",
    ),
    ('"act0"', '"act1"', r"s\.json:25:9: goal0/act1: act1 without act0"),
    ('"goal0"', '"goal2"', r"s\.json:23:5: goal2: goal2 without goal0"),
    (
        '"v_x": "10"',
        '"v_x": "1o"',
        r"s\.json:31:9: goal0/act0/blk0\.move\[0\]\.v_x: '1o' is not a number; did you mean 10\?",
    ),
    (
        '"toparse": "! {TRUE}"',
        '"toparse": ""',
        r"s\.json:163:9: goal0/act0/blk2\.toparse: the jump has no condition",
    ),
    (
        '"activityname": "test_act"',
        '"activityname": ""',
        r"s\.json:2:6: activityname: activityname must be a non-empty string",
    ),
    ('"goalid": "test_act_goal"', '"goalid": ""', r"goal0\.goalid: goalid must be a non-empty"),
    (
        '"track_path": "Silence"',
        '"track_path": " Silence"',
        r"goal0/act0/blk0\.audioout\[0\]\.track_path: track_path ' Silence' has surrounding spaces",
    ),
    (
        '"toparse": "! {TRUE}"',
        '"toparse": "! {TRUE}\\u0001"',
        r"goal0/act0/blk2\.toparse: the condition holds a control character",
    ),
    ('"rulecode": 0', '"rulecode": -1', r"alfarulemessages\[0\]\.rulecode: rulecode must be a"),
    ('"id": "kick_starter"', '"id": ""', r"alfarulemessages\[0\]\.id: the rule id must be"),
]


@pytest.mark.parametrize(("old", "new", "message"), JSON_ERRORS)
def test_json_problem_is_named_by_path_and_position(old, new, message):
    with pytest.raises(ScriptError, match=f"^{message}" if message.startswith("s") else message):
        load(replaced(old, new))


def test_script_without_goals_is_rejected():
    with pytest.raises(ScriptError, match=r"^s\.json:1:2: activityname: the script has no goal"):
        load('{"activityname": "a"}')


def test_goal_without_action_and_action_without_block_are_rejected():
    with pytest.raises(ScriptError, match=r"goal0: goal0 has no action"):
        load(json.dumps({"activityname": "a", "goal0": {"goalid": "g"}}))
    with pytest.raises(ScriptError, match=r"goal0/act0: goal0/act0 has no block"):
        load(json.dumps({"activityname": "a", "goal0": {"goalid": "g", "act0": {}}}))


def script(*blocks, alfa=(), omega=()) -> Script:
    return Script(
        activityname="a",
        alfarulemessages=tuple(alfa),
        omegarulemessages=tuple(omega),
        goals=(Goal(goalid="g", actions=(Action(blocks=tuple(blocks)),)),),
    )


def rule(action: RuleAction, mutex: MutexCmd) -> RuleMessage:
    return RuleMessage(rulecode=0, id="r", intopic="", outtopic="", action=action, mutexcmd=mutex)


def test_valid_struct_passes():
    validate_script(script(TerminusBlock()), source="<test>")


def test_struct_errors_have_paths_but_no_position():
    bad = script(InstructionBlock(move=(Move(v_x=0, v_y=0, v_theta=0, wait_t=1.5, duration=1),)))
    with pytest.raises(ScriptError, match=r"^<test>: goal0/act0/blk0\.move\[0\]\.wait_t: wait_t"):
        validate_script(bad, source="<test>")


def test_all_problems_are_listed_in_order():
    bad = script(
        InstructionBlock(led=(Led(r=2, g=0, b=0, turnas=1, wait_t=0, duration=-1),)),
        JumpBlock(toparse="! {TRUE}", truejump="goal0/act0/blk7"),
    )
    assert [e.path for e in script_errors(bad)] == [
        "goal0/act0/blk0.led[0].r",
        "goal0/act0/blk0.led[0].duration",
        "goal0/act0/blk1.truejump",
    ]


@pytest.mark.parametrize(
    ("alfa", "ok"),
    [
        ((MutexCmd.U,), True),
        ((MutexCmd.M, MutexCmd.M, MutexCmd.U), True),
        ((MutexCmd.M,), False),
        ((MutexCmd.U, MutexCmd.U), False),
        ((MutexCmd.L, MutexCmd.U), False),
    ],
)
def test_alfa_sequence_is_all_m_then_u(alfa, ok):
    errors = script_errors(script(TerminusBlock(), alfa=[rule(RuleAction.A, m) for m in alfa]))
    assert (not errors) is ok


@pytest.mark.parametrize(
    ("omega", "ok"),
    [
        ((MutexCmd.L,), True),
        ((MutexCmd.L, MutexCmd.M, MutexCmd.M), True),
        ((MutexCmd.M, MutexCmd.L), False),
        ((MutexCmd.L, MutexCmd.U), False),
        ((MutexCmd.L, MutexCmd.L), False),
    ],
)
def test_omega_sequence_is_l_then_all_m(omega, ok):
    errors = script_errors(script(TerminusBlock(), omega=[rule(RuleAction.R, m) for m in omega]))
    assert (not errors) is ok


def test_non_finite_speed_is_rejected():
    bad = script(
        InstructionBlock(move=(Move(v_x=float("nan"), v_y=0, v_theta=0, wait_t=0, duration=0),))
    )
    with pytest.raises(ScriptError, match=r"v_x must be a finite number"):
        validate_script(bad, source="<test>")
