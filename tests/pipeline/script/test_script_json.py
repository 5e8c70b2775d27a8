"""The thesis's Script JSON: listing 4.1, quoted numbers, letter codes, round trips."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from oimi.pipeline.messages import (
    InstructionBlock,
    JumpBlock,
    MutexCmd,
    RuleAction,
    SensorBlock,
    TerminusBlock,
)
from oimi.pipeline.script import ScriptError, dump_script_json, load_script_json

FIXTURES = Path(__file__).with_name("fixtures")
LISTING = (FIXTURES / "listing_4_1.json").read_text(encoding="utf-8")


def load(text: str | bytes):
    return load_script_json(text, source="s.json")


def test_listing_4_1_loads_with_its_content():
    script = load(LISTING)
    assert script.activityname == "test_act"
    (alfa,) = script.alfarulemessages
    assert (alfa.rulecode, alfa.id, alfa.action, alfa.mutexcmd) == (
        0,
        "kick_starter",
        RuleAction.C,
        MutexCmd.U,
    )
    (omega,) = script.omegarulemessages
    assert (omega.action, omega.mutexcmd) == (RuleAction.R, MutexCmd.L)
    (goal,) = script.goals
    assert goal.goalid == "test_act_goal"
    blocks = goal.actions[0].blocks
    assert [type(b) for b in blocks] == [
        InstructionBlock,
        InstructionBlock,
        JumpBlock,
        JumpBlock,
        TerminusBlock,
    ]
    first = blocks[0]
    assert first.flagged == "flag"
    assert [m.v_x for m in first.move] == [10.0, 0.0, 0.0, -10.0, 0.0, 0.0]
    assert first.move[4].v_theta == 50.0
    assert [(x.r, x.g, x.b) for x in first.led][:3] == [(1, 0, 0), (0, 1, 0), (0, 0, 1)]
    assert first.audioout[0].track_path == "Silence"
    assert blocks[1].audioout[0].track_path == "plugins/audio_control/songs/sounds_Excited_R2D2.wav"
    assert blocks[2] == JumpBlock(toparse="! {TRUE}", truejump="goal0/act0/blk4", falsejump="")


def test_listing_as_printed_is_rejected_at_the_line_broken_string():
    printed = (FIXTURES / "listing_4_1_as_printed.txt").read_text(encoding="utf-8")
    with pytest.raises(ScriptError, match=r"^s\.json:155:\d+: invalid JSON: Invalid control"):
        load(printed)


def test_dump_then_load_keeps_the_content():
    script = load(LISTING)
    assert load(dump_script_json(script)) == script


def test_dump_uses_thesis_keys_order_and_numeric_codes():
    document = json.loads(dump_script_json(load(LISTING)))
    assert list(document) == ["activityname", "alfarulemessages", "omegarulemessages", "goal0"]
    assert list(document["goal0"]) == ["goalid", "act0"]
    assert list(document["goal0"]["act0"]) == [f"blk{i}" for i in range(5)]
    assert list(document["goal0"]["act0"]["blk0"]) == [
        "type",
        "flagged",
        "move",
        "led",
        "audioout",
    ]
    assert document["alfarulemessages"][0]["action"] == 67
    assert document["alfarulemessages"][0]["mutexcmd"] == 85
    assert document["goal0"]["act0"]["blk0"]["move"][0]["v_x"] == "10"


def test_dump_of_listing_4_1_is_listing_4_1():
    assert json.loads(dump_script_json(load(LISTING))) == json.loads(LISTING)


def test_dump_writes_speeds_and_colours_as_quoted_numbers_like_the_thesis():
    document = json.loads(dump_script_json(load(LISTING)))
    blk0 = document["goal0"]["act0"]["blk0"]
    assert blk0["move"][4] == {
        "v_x": "0",
        "v_y": "0",
        "v_theta": "50",
        "wait_t": 1000,
        "duration": 1000,
    }
    assert blk0["led"][0] == {
        "r": "1",
        "g": "0",
        "b": "0",
        "turnas": 1,
        "wait_t": 0,
        "duration": 2000,
    }


def test_dump_is_pretty_with_four_spaces():
    assert dump_script_json(load(LISTING)).startswith('{\n    "activityname": "test_act",\n')


def minimal(**block) -> dict:
    block = block or {"type": "terminus"}
    return {"activityname": "a", "goal0": {"goalid": "g", "act0": {"blk0": block}}}


def test_plain_and_quoted_numbers_load_the_same():
    quoted = minimal(
        type="instruction",
        move=[{"v_x": "0.5", "v_y": "0", "v_theta": "-1", "wait_t": "10", "duration": 20}],
    )
    plain = minimal(
        type="instruction",
        move=[{"v_x": 0.5, "v_y": 0, "v_theta": -1, "wait_t": 10, "duration": 20}],
    )
    assert load(json.dumps(quoted)) == load(json.dumps(plain))


def test_letter_codes_load_like_numeric_codes():
    def with_codes(action, mutex):
        doc = minimal()
        doc["alfarulemessages"] = [
            {
                "rulecode": 0,
                "id": "k",
                "intopic": "",
                "outtopic": "",
                "action": action,
                "mutexcmd": mutex,
            }
        ]
        return load(json.dumps(doc))

    assert with_codes("C", "U") == with_codes(67, 85)
    assert with_codes("C", "U").alfarulemessages[0].action is RuleAction.C


def test_rule_message_lists_may_be_left_out():
    script = load(json.dumps(minimal()))
    assert script.alfarulemessages == () and script.omegarulemessages == ()


def test_sensor_block_keeps_its_request():
    script = load(json.dumps(minimal(type="sensor", request="camera")))
    assert script.goals[0].actions[0].blocks[0] == SensorBlock(request="camera")


def test_bytes_with_a_bom_are_read():
    assert load(b"\xef\xbb\xbf" + json.dumps(minimal()).encode()).activityname == "a"


SHAPE_ERRORS = [
    ("[]", r"1:1: Expected `object`, got `array` - at `\$`"),
    ('{"goal0": {}}', r"Object missing required field `activityname`"),
    (json.dumps({"activityname": 3}), r"1:2: Expected `str`, got `int` - at `activityname`"),
    (
        json.dumps(minimal(type="instruction", move={})),
        r"Expected `array`, got `object` - at `goal0/act0/blk0.move`",
    ),
    (
        json.dumps(minimal(type="instruction", colour=1)),
        r"Object contains unknown field `colour`.* - at `goal0/act0/blk0`",
    ),
    (json.dumps(minimal(type="jump")), r"missing required field `toparse`"),
    (json.dumps({**minimal(), "extra": 1}), r"unknown field `extra`"),
    (
        json.dumps(
            minimal(type="instruction", led=[{"r": 1, "g": 0, "b": 0, "turnas": 1, "wait_t": 0}])
        ),
        r"missing required field `duration` - at `goal0/act0/blk0.led\[0\]`",
    ),
    (
        json.dumps(
            minimal(
                type="instruction",
                move=[{"v_x": True, "v_y": 0, "v_theta": 0, "wait_t": 0, "duration": 0}],
            )
        ),
        r"Expected `float`, got `bool` - at `goal0/act0/blk0.move\[0\].v_x`",
    ),
    ('{"activityname": "a", "activityname": "b"}', r"1:23: duplicate key 'activityname'"),
    ('{"activityname": NaN}', r"1:18: NaN and Infinity"),
    ("{", r"1:2: invalid JSON"),
    ("", r"1:1: empty file"),
]


@pytest.mark.parametrize(("text", "message"), SHAPE_ERRORS)
def test_wrong_shapes_are_named_with_their_path(text, message):
    with pytest.raises(ScriptError, match=message):
        load(text)


def test_shape_error_points_at_the_key_line():
    text = LISTING.replace('"v_y": "10"', '"v_y": [10]')
    with pytest.raises(ScriptError, match=r"^s\.json:39:\d+: Expected `float`, got `array`"):
        load(text)


def test_binary_file_is_rejected():
    with pytest.raises(ScriptError, match=r"^s\.json:1:3: not a text script \(it contains NUL"):
        load(b'{"\x00')


def test_non_utf8_file_is_rejected():
    with pytest.raises(ScriptError, match=r"^s\.json:2:3: .*invalid UTF-8 byte 0xff"):
        load(b'{\n "\xff": 1}')
