"""The structural checks the handler applies to generated scripts."""

from __future__ import annotations

from pipeline.messages import (
    Action,
    AudioOut,
    Goal,
    InstructionBlock,
    JumpBlock,
    Led,
    Move,
    MutexCmd,
    RuleAction,
    RuleMessage,
    Script,
)
from pipeline.operator.checks import script_paths, script_problems


def rule(mutex: MutexCmd, rid: str = "r", code: int = 1) -> RuleMessage:
    return RuleMessage(
        rulecode=code, id=rid, intopic="", outtopic="", action=RuleAction.A, mutexcmd=mutex
    )


def script(*blocks, goalid="g", alfa=(), omega=()) -> Script:
    return Script(
        activityname="t",
        alfarulemessages=alfa,
        omegarulemessages=omega,
        goals=(Goal(goalid=goalid, actions=(Action(blocks=blocks),)),),
    )


OK_BLOCK = InstructionBlock(led=(Led(r=0, g=0, b=1, turnas=1, wait_t=0, duration=100),))


def test_a_well_formed_script_has_no_problems():
    s = script(
        OK_BLOCK,
        JumpBlock(toparse="! {TRUE}", truejump="goal0/act0/blk0"),
        alfa=(rule(MutexCmd.M), rule(MutexCmd.U)),
        omega=(rule(MutexCmd.L), rule(MutexCmd.M)),
    )
    assert script_problems(s) == ()
    assert script_paths(s) == ("goal0/act0/blk0", "goal0/act0/blk1")


def test_alfa_must_end_with_u_and_never_use_l():
    s = script(OK_BLOCK, alfa=(rule(MutexCmd.L, "x"), rule(MutexCmd.M, "y")))
    assert script_problems(s) == (
        "alfa[0] (x): mutexcmd is L, expected M",
        "alfa[1] (y): mutexcmd is M, expected U",
    )


def test_omega_must_start_with_l_and_never_use_u():
    s = script(OK_BLOCK, omega=(rule(MutexCmd.M, "x"), rule(MutexCmd.U, "y")))
    assert script_problems(s) == (
        "omega[0] (x): mutexcmd is M, expected L",
        "omega[1] (y): mutexcmd is U, expected M",
    )


def test_missing_jump_targets_are_named():
    s = script(JumpBlock(toparse="! {TRUE}", truejump="goal0/act0/blk9", falsejump="goal1"))
    assert script_problems(s) == (
        "goal0/act0/blk0: truejump 'goal0/act0/blk9' is not a block of the script",
        "goal0/act0/blk0: falsejump 'goal1' is not a block of the script",
    )


def test_out_of_range_values_are_named():
    s = script(
        InstructionBlock(
            move=(Move(v_x=0, v_y=0, v_theta=0, wait_t=-1, duration=5),),
            led=(Led(r=1.5, g=0, b=-0.1, turnas=2, wait_t=0, duration=-3),),
            audioout=(AudioOut(track_path="", wait_t=0, duration=1),),
        )
    )
    assert script_problems(s) == (
        "goal0/act0/blk0/move[0]: wait_t -1 is negative",
        "goal0/act0/blk0/led[0]: duration -3 is negative",
        "goal0/act0/blk0/led[0]: r 1.5 is outside [0, 1]",
        "goal0/act0/blk0/led[0]: b -0.1 is outside [0, 1]",
        "goal0/act0/blk0/led[0]: turnas 2 is not 0 or 1",
        "goal0/act0/blk0/audioout[0]: empty track_path",
    )


def test_empty_and_repeated_structure_is_named():
    assert script_problems(Script(activityname="")) == ("empty activityname", "no goals")
    twice = Script(
        activityname="t",
        goals=(
            Goal(goalid="g", actions=(Action(blocks=(OK_BLOCK,)),)),
            Goal(goalid="g"),
            Goal(goalid="", actions=(Action(),)),
        ),
    )
    assert script_problems(twice) == (
        "goal1: goalid 'g' repeats",
        "goal1: no actions",
        "goal2: empty goalid",
        "goal2/act0: no blocks",
    )


def test_empty_jump_condition_is_named():
    assert script_problems(script(JumpBlock(toparse=" "))) == (
        "goal0/act0/blk0: empty jump condition",
    )
