"""The Block Reader: block kinds, the LIFO over the idle activity, switches, goals."""

from __future__ import annotations

from oimi.pipeline.events import ProgressKind
from oimi.pipeline.messages import (
    Action,
    Goal,
    GoalStatus,
    InstructionBlock,
    JumpBlock,
    Led,
    MutexCmd,
    RuleAction,
    RuleMessage,
    Script,
    SensorBlock,
    TerminusBlock,
    WorldMap,
)
from oimi.pipeline.think.reader import MAX_BLOCKS_PER_READ, BlockReader, ScriptEntry, parse_path


def inst(tag: str) -> InstructionBlock:
    return InstructionBlock(
        led=(Led(r=1, g=0, b=0, turnas=1, wait_t=0, duration=100),), flagged=tag
    )


def script(name: str, *goals: list[list[object]], alfa=(), omega=()) -> Script:
    return Script(
        activityname=name,
        alfarulemessages=alfa,
        omegarulemessages=omega,
        goals=tuple(
            Goal(goalid=f"{name}_g{i}", actions=tuple(Action(blocks=tuple(a)) for a in g))
            for i, g in enumerate(goals)
        ),
    )


IDLE = ScriptEntry(
    activity="idle_activity",
    source="idle_activity",
    script=script(
        "idle_activity", [[inst("idle"), JumpBlock(toparse="! {TRUE}", truejump="goal0/act0/blk0")]]
    ),
)


def reader(library: dict[str, Script] | None = None) -> BlockReader:
    library = library or {}
    world = WorldMap()

    def resolve(name: str) -> ScriptEntry | None:
        found = library.get(name)
        return (
            ScriptEntry(activity=found.activityname, script=found, source=name) if found else None
        )

    r = BlockReader(world, idle=IDLE, resolve=resolve)
    r.start(now_ms=0)
    return r


def shown(r: BlockReader) -> str | None:
    block = r.map.scriptinfo.block
    return block.flagged if block else None


def entry(s: Script, **kw) -> ScriptEntry:
    return ScriptEntry(activity=s.activityname, script=s, source=s.activityname, **kw)


def test_the_idle_activity_runs_when_the_lifo_is_empty_and_loops() -> None:
    r = reader()
    r.read(actuator_done=True, now_ms=0)
    assert shown(r) == "idle" and r.map.scriptinfo.currentactivity == "idle_activity"
    out = r.read(actuator_done=True, now_ms=100)
    assert [i.kind for i in out.items] == [ProgressKind.JUMP, ProgressKind.BLOCK]
    assert r.take_new_block(), "the same block read again is a new block for the actuator"


def test_reading_waits_for_the_actuator_to_finish_the_block() -> None:
    r = reader()
    r.read(actuator_done=True, now_ms=0)
    assert r.read(actuator_done=False, now_ms=20).items == []


def test_jump_true_false_and_empty_targets() -> None:
    s = script(
        "j",
        [
            [
                JumpBlock(toparse="! {TRUE}", truejump="goal0/act0/blk2"),
                inst("skipped"),
                JumpBlock(
                    toparse="{CLASS #Human L ?nobody} ! {TRUE}",
                    truejump="goal0/act0/blk1",
                    falsejump="",
                ),
                inst("after_false"),
            ]
        ],
    )
    r = reader()
    r.push([entry(s)])
    r.escape_idle(now_ms=0)
    out = r.read(actuator_done=True, now_ms=0)
    assert shown(r) == "after_false"
    assert [i.detail for i in out.items if i.kind == ProgressKind.JUMP] == [
        "True -> goal0/act0/blk2",
        "False -> next",
    ]


def test_terminus_ends_the_script_and_the_next_one_in_the_lifo_runs() -> None:
    first = script("first", [[inst("a"), TerminusBlock(), inst("never")]])
    second = script("second", [[inst("b")]])
    r = reader()
    r.push([entry(second), entry(first)])
    r.escape_idle(now_ms=0)
    r.read(actuator_done=True, now_ms=0)
    assert shown(r) == "a"
    out = r.read(actuator_done=True, now_ms=100)
    assert shown(r) == "b"
    assert ("first", True) in out.finished and "second" in out.started
    out = r.read(actuator_done=True, now_ms=200)
    assert shown(r) == "idle" and ("second", True) in out.finished


def test_sensor_blocks_emit_a_request_and_move_on() -> None:
    s = script("s", [[SensorBlock(request="look"), inst("x")]])
    r = reader()
    r.push([entry(s)])
    r.escape_idle(now_ms=0)
    out = r.read(actuator_done=True, now_ms=0)
    assert [(i.kind, i.detail) for i in out.items if i.kind == ProgressKind.SENSOR] == [
        (ProgressKind.SENSOR, "look")
    ]
    assert shown(r) == "x"


def test_alfa_on_load_and_omega_on_end_in_order() -> None:
    alfa = (
        RuleMessage(
            rulecode=1, id="r", intopic="", outtopic="", action=RuleAction.A, mutexcmd=MutexCmd.U
        ),
    )
    omega = (
        RuleMessage(
            rulecode=1, id="r", intopic="", outtopic="", action=RuleAction.R, mutexcmd=MutexCmd.L
        ),
    )
    s = script("s", [[inst("x")]], alfa=alfa, omega=omega)
    r = reader()
    r.push([entry(s)])
    out = r.escape_idle(now_ms=0)
    assert out.rule_messages == list(alfa) and not out.unlock
    out = r.read(actuator_done=True, now_ms=0)
    out = r.read(actuator_done=True, now_ms=10)
    assert list(omega) == [m for m in out.rule_messages if m.id == "r"]


def test_goals_are_reached_when_their_actions_finish() -> None:
    s = script("g", [[inst("a")]], [[inst("b")]])
    r = reader()
    r.push([entry(s)])
    r.escape_idle(now_ms=0)
    r.read(actuator_done=True, now_ms=0)
    out = r.read(actuator_done=True, now_ms=100)
    assert [i.detail for i in out.items if i.kind == ProgressKind.GOAL_REACHED] == ["g_g0"]
    goals = r.map.robotstatus.activities[-1].goals
    assert [g.status for g in goals] == [GoalStatus.REACHED, GoalStatus.ACTIVE]
    assert [e.goalid for e in r.map.robotstatus.goalreached] == ["g_g0"]


def test_a_compulsory_switch_loads_the_named_script_and_resumes_the_interrupted_one() -> None:
    game = script("game", [[inst("play1")]], [[inst("play2")]])
    wait = script("wait_for_child", [[inst("wait")]])
    r = reader({"wait_for_child": wait})
    r.push([entry(game)])
    r.escape_idle(now_ms=0)
    r.read(actuator_done=True, now_ms=0)
    r.read(actuator_done=True, now_ms=100)
    assert shown(r) == "play2"
    info = r.map.scriptinfo
    info.currentactivity, info.goalid, info.actionid, info.blockid = (
        "wait_for_child",
        "goal0",
        "act0",
        "blk0",
    )
    info.overridecmd = True
    out = r.compulsory_switch(now_ms=150)
    assert out.finished == [], "suspended, not finished: the operator still sees it current"
    assert [e.activity for e in r.lifo] == ["game"] and r.map.scriptinfo.script_vect == ["game"]
    assert r.map.robotstatus.goalinterrupted[-1].goalid == "game_g1"
    r.read(actuator_done=False, now_ms=150)
    assert shown(r) == "wait" and not info.overridecmd
    r.read(actuator_done=True, now_ms=200)
    assert shown(r) == "play2", "the interrupted script resumes at the goal it was in"


def test_a_switch_to_an_unknown_script_is_refused_and_logged() -> None:
    r = reader()
    r.map.scriptinfo.currentactivity = "nowhere"
    r.map.scriptinfo.goalid, r.map.scriptinfo.actionid, r.map.scriptinfo.blockid = (
        "goal0",
        "act0",
        "blk0",
    )
    r.map.scriptinfo.overridecmd = True
    out = r.compulsory_switch(now_ms=0)
    assert "no script 'nowhere'" in out.logs[0].message
    assert r.map.scriptinfo.currentactivity == "idle_activity"


def test_script_vect_changes_rebuild_the_lifo_and_restart_switches_now() -> None:
    other = script("other", [[inst("o")]])
    r = reader({"activities/other.json": other})
    r.map.scriptinfo.script_vect = ["activities/other.json", "activities/missing.json"]
    r.map.scriptinfo.restart = True
    out = r.sync_lifo(now_ms=0)
    assert "no script 'activities/missing.json'" in out.logs[0].message
    r.read(actuator_done=True, now_ms=0)
    assert shown(r) == "o" and r.map.scriptinfo.script_vect == []


def test_a_jump_loop_without_instructions_is_ended_not_spun_forever() -> None:
    s = script("spin", [[JumpBlock(toparse="! {TRUE}", truejump="goal0/act0/blk0")]])
    r = reader()
    r.push([entry(s)])
    r.escape_idle(now_ms=0)
    out = r.read(actuator_done=True, now_ms=0)
    assert f"{MAX_BLOCKS_PER_READ} blocks" in out.logs[0].message
    assert ("spin", False) in out.finished and r.map.robotstatus.goalfailed[-1].goalid == "spin_g0"
    r.read(actuator_done=False, now_ms=20)
    assert shown(r) == "idle"


def test_a_script_with_a_bad_jump_condition_is_not_loaded() -> None:
    s = script("bad", [[JumpBlock(toparse="! {E: nope ()}"), inst("x")]])
    r = reader()
    r.push([entry(s)])
    out = r.escape_idle(now_ms=0)
    assert "bad: not loaded" in out.logs[0].message and ("bad", False) in out.finished
    assert r.map.scriptinfo.currentactivity == "idle_activity"


def test_stop_drops_the_operators_scripts_and_returns_to_idle() -> None:
    a, b = script("a", [[inst("a")]]), script("b", [[inst("b")]])
    r = reader()
    r.push([entry(b, operator=True), entry(a, operator=True)])
    r.escape_idle(now_ms=0)
    out = r.stop_operator_activities(now_ms=10)
    assert ("a", False) in out.finished and r.lifo == []
    r.read(actuator_done=False, now_ms=10)
    assert shown(r) == "idle"


def test_parse_path() -> None:
    assert parse_path("goal1/act2/blk3") == (1, 2, 3)


def force(r: BlockReader, activity: str, path: str = "goal0/act0/blk0") -> None:
    info = r.map.scriptinfo
    info.currentactivity = activity
    info.goalid, info.actionid, info.blockid = path.split("/")
    info.overridecmd = True


def test_an_override_naming_the_running_script_only_repositions_it() -> None:
    """Thesis 4.2 step 5: "the Block Reader loads the (Rule-setted) Script reported in field
    currentactivity at Goal, Action, Block reported in Script Info sub-fields goalid, actionid,
    blockid" -- for the running script that is a move, not a second copy."""
    alfa = (
        RuleMessage(
            rulecode=1, id="x", intopic="", outtopic="", action=RuleAction.A, mutexcmd=MutexCmd.U
        ),
    )
    omega = (
        RuleMessage(
            rulecode=1, id="x", intopic="", outtopic="", action=RuleAction.R, mutexcmd=MutexCmd.L
        ),
    )
    game = script(
        "game", [[inst("play1")]], [[inst("play2")]], [[inst("play3")]], alfa=alfa, omega=omega
    )
    r = reader()
    r.push([entry(game)])
    r.escape_idle(now_ms=0)
    r.read(actuator_done=True, now_ms=0)
    assert shown(r) == "play1"
    force(r, "game", "goal2/act0/blk0")
    out = r.compulsory_switch(now_ms=100)
    assert out.rule_messages == [], "no omega, no alfa"
    assert out.finished == [] and out.started == []
    assert r.lifo == [] and r.map.scriptinfo.script_vect == [], "no suspended copy"
    assert [i.kind for i in out.items] == [ProgressKind.SWITCH]
    r.read(actuator_done=False, now_ms=100)
    assert shown(r) == "play3" and r.map.scriptinfo.currentactivity == "game"
    out = r.read(actuator_done=True, now_ms=200)
    assert out.rule_messages == list(omega) and ("game", True) in out.finished
    assert shown(r) == "idle", "the script ran once: nothing waits in the LIFO"


def test_an_override_naming_the_idle_activity_while_idle_does_not_reload_it() -> None:
    """Thesis 4.2 step 5: the reader loads the Script "at Goal, Action, Block reported in
    Script Info"; the idle activity's alfa messages are not sent a second time."""
    r = reader()
    r.read(actuator_done=True, now_ms=0)
    force(r, "idle_activity")
    out = r.compulsory_switch(now_ms=20)
    assert out.rule_messages == [] and out.started == [] and out.finished == []


def test_a_rule_switch_reaches_a_generators_last_script() -> None:
    """Thesis 4.2 step 5: "the Block Reader loads the (Rule-setted) Script reported in field
    currentactivity" -- an activity, however its script was made (3.2: generators produce
    Scripts on demand)."""
    dance = script("test_dance", [[inst("dance")]])
    r = reader()  # no script file named test_dance
    r.push(
        [
            ScriptEntry(
                activity="test_dance", script=dance, source="generator:test_dance", operator=True
            )
        ]
    )
    r.escape_idle(now_ms=0)
    r.read(actuator_done=True, now_ms=0)
    r.read(actuator_done=True, now_ms=100)
    assert shown(r) == "idle", "the generated script ran and ended"
    force(r, "test_dance")
    out = r.compulsory_switch(now_ms=200)
    assert out.logs == [] and out.started == ["test_dance"]
    r.read(actuator_done=False, now_ms=200)
    assert shown(r) == "dance" and r.map.scriptinfo.scriptpath == "generator:test_dance"


def test_a_rule_switch_reaches_a_file_script_and_the_idle_activity() -> None:
    """Thesis 4.2 step 5 and 3.2: a switch names a Script file or the "idle_activity"."""
    wait = script("wait_for_child", [[inst("wait")]])
    game = script("game", [[inst("play1")]])
    r = reader({"wait_for_child": wait})
    r.push([entry(game)])
    r.escape_idle(now_ms=0)
    force(r, "wait_for_child")
    r.compulsory_switch(now_ms=10)
    r.read(actuator_done=False, now_ms=10)
    assert shown(r) == "wait"
    force(r, "idle_activity")
    out = r.compulsory_switch(now_ms=20)
    assert out.logs == []
    r.read(actuator_done=False, now_ms=20)
    assert shown(r) == "idle"
