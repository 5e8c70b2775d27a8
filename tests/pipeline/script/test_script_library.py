"""The shipped activities: they load, the twins agree, and the idle loop is gentle and endless."""

from __future__ import annotations

from pathlib import Path

import pytest
from oimi.pipeline.messages import InstructionBlock, JumpBlock, MutexCmd, RuleAction
from oimi.pipeline.script import compile_dsl, load_script_json, parse_script

ACTIVITIES = Path(__file__).parents[3] / "scenarios" / "library" / "activities"
FIXTURES = Path(__file__).with_name("fixtures")


def load(name: str):
    path = ACTIVITIES / name
    return parse_script(path.read_bytes(), source=str(path)).script


SCRIPT_FILES = [p for p in sorted(ACTIVITIES.iterdir()) if p.suffix in (".txt", ".json")]


@pytest.mark.parametrize("path", SCRIPT_FILES, ids=lambda p: p.name)
def test_every_shipped_activity_loads(path):
    assert parse_script(path.read_bytes(), source=str(path)).script.goals


def test_test_act_json_is_listing_4_1():
    listing = load_script_json((FIXTURES / "listing_4_1.json").read_bytes(), source="l")
    assert load("test_act.json") == listing
    assert load("test_act.txt") == listing


def test_idle_activity_twins_agree():
    assert load("idle_activity.json") == load("idle_activity.txt")


def test_idle_activity_is_gentle_dim_and_balanced():
    idle = load("idle_activity.json")
    assert idle.activityname == "idle_activity"
    blocks = [b for g in idle.goals for a in g.actions for b in a.blocks]
    instructions = [b for b in blocks if isinstance(b, InstructionBlock)]
    moves = [m for b in instructions for m in b.move]
    assert moves and all(abs(m.v_theta) <= 0.2 for m in moves)
    assert all(abs(m.v_x) <= 0.05 and abs(m.v_y) <= 0.05 for m in moves)
    turn = sum(m.v_theta * m.duration for m in moves)
    shift = sum(m.v_x * m.duration for m in moves)
    assert turn == pytest.approx(0) and shift == pytest.approx(0)
    leds = [x for b in instructions for x in b.led]
    assert all(x.r == 0 and x.g == 0 and x.b <= 0.5 for x in leds)
    assert len({x.b for x in leds}) > 3  # steps up and down


def test_idle_activity_loops_forever_with_kick_starter():
    idle = load("idle_activity.json")
    last = idle.goals[-1].actions[-1].blocks[-1]
    assert isinstance(last, JumpBlock)
    assert last.toparse == "! {TRUE}"
    assert last.truejump == last.falsejump == "goal0/act0/blk0"
    (alfa,) = idle.alfarulemessages
    (omega,) = idle.omegarulemessages
    assert (alfa.id, alfa.action, alfa.mutexcmd) == ("kick_starter", RuleAction.C, MutexCmd.U)
    assert (omega.id, omega.action, omega.mutexcmd) == ("kick_starter", RuleAction.R, MutexCmd.L)


def test_example_act_is_the_corrected_thesis_example():
    example = compile_dsl((ACTIVITIES / "example_act.txt").read_text(encoding="utf-8"), source="e")
    assert example.activityname == "example_act"
    assert [m.id for m in example.alfarulemessages] == ["my_rule", "kick_starter"]
    (block,) = example.goals[0].actions[0].blocks
    assert [(x.b, x.duration) for x in block.led] == [(1, 100), (1, 100)]
