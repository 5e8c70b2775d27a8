"""The shipped generators: valid, deterministic scripts whose options matter."""

from __future__ import annotations

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from oimi.pipeline.messages import InstructionBlock, JumpBlock, MutexCmd, RuleAction, Script
from oimi.pipeline.operator.generators import (
    BlinkGenerator,
    DanceGenerator,
    GreetingGenerator,
    JointAttentionGenerator,
    default_catalogue,
)
from oimi.pipeline.script.validate import script_errors
from oimi.pipeline.think.conditions import compile_condition
from oimi.pipeline.think.rulecodes import RuleCode

ALL = [DanceGenerator, GreetingGenerator, JointAttentionGenerator, BlinkGenerator]


def generate(cls, **options: str) -> Script:
    g = cls()
    g.activate(options)
    return g.generate()


def blocks(script: Script):
    for g, goal in enumerate(script.goals):
        for a, action in enumerate(goal.actions):
            for b, block in enumerate(action.blocks):
                yield f"goal{g}/act{a}/blk{b}", block


@pytest.mark.parametrize("cls", ALL, ids=lambda c: c.name)
def test_default_script_passes_every_check(cls):
    script = generate(cls)
    assert script_errors(script) == []
    assert script.activityname == cls.name
    alfa = [m.mutexcmd for m in script.alfarulemessages]
    omega = [m.mutexcmd for m in script.omegarulemessages]
    assert alfa[-1] is MutexCmd.U and all(m is MutexCmd.M for m in alfa[:-1])
    assert omega[0] is MutexCmd.L and all(m is MutexCmd.M for m in omega[1:])


@pytest.mark.parametrize("cls", ALL, ids=lambda c: c.name)
def test_goalids_are_meaningful_and_distinct(cls):
    ids = [g.goalid for g in generate(cls).goals]
    assert len(set(ids)) == len(ids)
    assert all(len(i) > 4 and not i.startswith("goal") for i in ids)


@pytest.mark.parametrize("cls", ALL, ids=lambda c: c.name)
def test_jump_targets_exist_and_conditions_compile(cls):
    script = generate(cls)
    paths = {
        f"goal{g}/act{a}/blk{b}"
        for g, goal in enumerate(script.goals)
        for a, action in enumerate(goal.actions)
        for b in range(len(action.blocks))
    }
    for _, block in blocks(script):
        if isinstance(block, JumpBlock):
            assert block.truejump in paths | {""}
            assert block.falsejump in paths | {""}
            compile_condition(block.toparse)


@pytest.mark.parametrize("cls", ALL, ids=lambda c: c.name)
def test_generation_is_deterministic_and_round_trips_as_json(cls):
    a, b = generate(cls), generate(cls)
    assert msgspec.json.encode(a) == msgspec.json.encode(b)
    assert msgspec.json.decode(msgspec.json.encode(a), type=Script) == a


@pytest.mark.parametrize(
    "cls", [DanceGenerator, GreetingGenerator, JointAttentionGenerator], ids=lambda c: c.name
)
def test_moving_generators_load_and_unload_the_safety_rule(cls):
    script = generate(cls)
    first = script.alfarulemessages[0]
    assert (first.rulecode, first.id, first.action) == (
        RuleCode.CHILD_TOO_CLOSE,
        "child_too_close",
        RuleAction.A,
    )
    removed = [m for m in script.omegarulemessages if m.id == "child_too_close"]
    assert [m.action for m in removed] == [RuleAction.R]


def _moves(script: Script):
    for _, block in blocks(script):
        if isinstance(block, InstructionBlock):
            yield from block.move


@settings(max_examples=40, deadline=None)
@given(
    tempo=st.one_of(st.sampled_from(["slow", "medium", "fast"]), st.integers(40, 160).map(str)),
    colours=st.lists(
        st.sampled_from(["red", "green", "blue", "#336699", "white"]), min_size=1, max_size=4
    ).map(",".join),
    reps=st.integers(1, 10).map(str),
    seed=st.integers(0, 1000).map(str),
)
def test_dance_is_valid_and_gentle_for_any_options(tempo, colours, reps, seed):
    script = generate(DanceGenerator, tempo=tempo, colours=colours, repetitions=reps, seed=seed)
    assert script_errors(script) == []
    for m in _moves(script):
        assert abs(m.v_x) <= 0.4 and abs(m.v_y) <= 0.4 and abs(m.v_theta) <= 1.2


def test_dance_moves_lights_and_track_are_on_the_same_beat():
    script = generate(DanceGenerator, tempo="fast", track="songs/x.wav")
    beat_ms = 500
    figures = script.goals[1].actions[0].blocks[0]
    assert isinstance(figures, InstructionBlock)
    assert all(m.duration == 2 * beat_ms for m in figures.move)
    assert all(led.duration == beat_ms for led in figures.led)
    total = sum(m.duration for m in figures.move)
    assert total == sum(led.duration for led in figures.led) == figures.audioout[0].duration
    assert figures.audioout[0].track_path == "songs/x.wav"


def test_dance_figures_bring_the_robot_back_where_it_started():
    for m_sum in [
        (
            sum(m.v_x * m.duration for m in b.move),
            sum(m.v_y * m.duration for m in b.move),
            sum(m.v_theta * m.duration for m in b.move),
        )
        for _, b in blocks(generate(DanceGenerator, repetitions="3"))
        if isinstance(b, InstructionBlock)
    ]:
        assert m_sum == pytest.approx((0.0, 0.0, 0.0))


@pytest.mark.parametrize(
    ("option", "a", "b"),
    [
        ("tempo", "slow", "fast"),
        ("colours", "red", "blue,green"),
        ("repetitions", "1", "3"),
        ("track", "a.wav", "b.wav"),
        ("seed", "1", "2"),
    ],
)
def test_each_dance_option_changes_the_script(option, a, b):
    assert generate(DanceGenerator, **{option: a}) != generate(DanceGenerator, **{option: b})


def test_dance_repetitions_are_actions_of_the_figures_goal():
    script = generate(DanceGenerator, repetitions="4")
    assert [g.goalid for g in script.goals] == ["dance_warm_up", "dance_figures", "dance_bow"]
    assert len(script.goals[1].actions) == 4


def test_dance_colours_cycle_on_the_beat():
    script = generate(DanceGenerator, colours="red,blue", repetitions="1")
    leds = script.goals[1].actions[0].blocks[0].led  # type: ignore[union-attr]
    assert [(x.r, x.g, x.b) for x in leds[:3]] == [(1, 0, 0), (0, 0, 1), (1, 0, 0)]


def test_greeting_approaches_until_near_then_greets():
    script = generate(GreetingGenerator, distance_m="0.8", steps="3", sound="hi.wav")
    assert [g.goalid for g in script.goals] == [
        "turn_to_child",
        "approach_child",
        "greet_child",
        "no_child_found",
    ]
    greet = "goal2/act0/blk0"
    near = [
        b
        for _, b in blocks(script)
        if isinstance(b, JumpBlock) and "near (?child, 0.8)" in b.toparse
    ]
    assert near and all(b.truejump == greet for b in near)
    assert len(near) == 4  # one per step and a last check
    greeting = dict(blocks(script))[greet]
    assert greeting.audioout[0].track_path == "hi.wav"
    assert max(m.v_x for m in _moves(script)) == pytest.approx(0.15)


def test_greeting_steps_bound_the_search():
    short = generate(GreetingGenerator, steps="2")
    long = generate(GreetingGenerator, steps="6")
    assert len(short.goals[0].actions[0].blocks) == 2 * 2 + 1
    assert len(long.goals[0].actions[0].blocks) == 2 * 6 + 1


def test_joint_attention_has_three_goals_per_round_and_bounded_waits():
    script = generate(JointAttentionGenerator, rounds="2", tries="4", colours="red")
    assert [g.goalid for g in script.goals] == [
        "round1_look_at_target",
        "round1_child_attends",
        "round1_reward",
        "round2_look_at_target",
        "round2_child_attends",
        "round2_reward",
        "game_over",
    ]
    waits = script.goals[1].actions[0].blocks
    assert sum(isinstance(b, JumpBlock) for b in waits) == 4 + 1
    assert waits[-1] == JumpBlock(toparse="! {TRUE}", truejump="goal3/act0/blk0")
    assert any(
        "?THIS>&istarget" in b.toparse
        for b in script.goals[0].actions[0].blocks
        if isinstance(b, JumpBlock)
    )


def test_blink_is_the_thesis_example_act():
    script = generate(BlinkGenerator)
    assert script.activityname == "example_act"
    assert [g.goalid for g in script.goals] == ["blinking_and_stop"]
    (block,) = script.goals[0].actions[0].blocks
    assert [(x.r, x.g, x.b, x.turnas, x.wait_t, x.duration) for x in block.led] == [
        (0, 0, 1, 1, 0, 100)
    ] * 2
    assert [(m.id, m.action, m.mutexcmd) for m in script.alfarulemessages] == [
        ("child_too_close", RuleAction.A, MutexCmd.M),
        ("kick_starter", RuleAction.R, MutexCmd.U),
    ]
    assert [(m.id, m.action, m.mutexcmd) for m in script.omegarulemessages] == [
        ("kick_starter", RuleAction.C, MutexCmd.L),
        ("child_too_close", RuleAction.R, MutexCmd.M),
    ]


def test_every_catalogue_entry_generates_with_its_defaults():
    cat = default_catalogue()
    for name in cat.names():
        g = cat.create(name)
        g.activate({})
        assert script_errors(g.generate()) == []
