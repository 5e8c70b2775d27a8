"""The Generator Handler: every command in every button state, the full cycle, effects."""

from __future__ import annotations

from collections.abc import Mapping

import msgspec
import pytest
from oimi.pipeline.messages import Action as ScriptAction
from oimi.pipeline.messages import (
    Goal,
    InstructionBlock,
    Led,
    MutexCmd,
    RuleAction,
    RuleMessage,
    Script,
)
from oimi.pipeline.operator.commands import (
    Add,
    Clear,
    Command,
    GetReady,
    ListActivities,
    Remove,
    Reorder,
    Restart,
    Start,
    Stop,
)
from oimi.pipeline.operator.generator import Catalogue, GeneratorError, OptionKind, OptionSpec
from oimi.pipeline.operator.handler import (
    ActivityState,
    GeneratorHandler,
    OperatorButton,
    PushScripts,
    StopActivities,
)

NYC = ActivityState.NOT_YET_COMPLETED.value
CUR = ActivityState.CURRENT.value
DONE = ActivityState.COMPLETED.value


def _script(name: str) -> Script:
    block = InstructionBlock(led=(Led(r=0, g=0, b=1, turnas=1, wait_t=0, duration=100),))
    return Script(
        activityname=name,
        goals=(Goal(goalid=f"{name}_goal", actions=(ScriptAction(blocks=(block,)),)),),
    )


class Spy:
    """A generator that records its lifecycle calls; ``fail`` makes ``generate`` raise."""

    options = (OptionSpec(name="level", kind=OptionKind.NUMBER, default="1", min=1, max=3),)

    def __init__(
        self, name: str, log: list[str], *, fail: bool = False, script: Script | None = None
    ):
        self.name = self.title = name
        self.description = "spy"
        self.log = log
        self.fail = fail
        self.script = script or _script(f"{name}_script")

    def activate(self, options: Mapping[str, str]) -> None:
        self.log.append(f"activate {self.name} {dict(options)}")

    def generate(self) -> Script:
        self.log.append(f"generate {self.name}")
        if self.fail:
            raise GeneratorError("cannot see the ball", source=self.name)
        return self.script

    def shutdown(self) -> None:
        self.log.append(f"shutdown {self.name}")


class Env:
    def __init__(self, **extra):
        self.log: list[str] = []
        factories = {n: (lambda n=n: Spy(n, self.log)) for n in ("a", "b", "c")}
        factories.update(
            {k: (lambda k=k, kw=kw: Spy(k, self.log, **kw)) for k, kw in extra.items()}
        )
        self.h = GeneratorHandler(Catalogue(factories))
        self.next_id = 0

    def do(self, kind: type[Command], activity: str = "", **kw):
        self.next_id += 1
        cmd = kind(id=self.next_id, **({"activity": activity} if activity else {}), **kw)
        result = self.h.handle(cmd, now_ms=self.next_id * 20)
        assert result.reply.id == self.next_id
        return result

    def ok(self, verb: type[Command], activity: str = "", **kw):
        result = self.do(verb, activity, **kw)
        assert result.reply.ok, result.reply.reason
        return result

    def refused(self, verb: type[Command], activity: str = "", *, match: str, **kw) -> None:
        before = (self.h.button, self.h.activities(), list(self.log))
        result = self.do(verb, activity, **kw)
        assert not result.reply.ok
        assert result.effects == ()
        assert match in result.reply.reason, result.reply.reason
        assert (self.h.button, self.h.activities(), self.log) == before

    def states(self) -> list[tuple[str, str]]:
        return [(e.name, e.state) for e in self.h.activities()]

    def ready(self, *names: str) -> None:
        for n in names:
            self.ok(Add, n)
        self.ok(GetReady)
        self.h.tick(0)
        assert self.h.button is OperatorButton.START


# ------------------------------------------------------------------- the cycle


def test_full_cycle_from_add_to_clear():
    env = Env()
    h = env.h
    assert h.button is OperatorButton.GET_READY
    env.ok(Add, "a", options={"level": "2"})
    env.ok(Add, "b")
    assert env.states() == [("a", NYC), ("b", NYC)]
    assert h.activities()[0].options == {"level": "2"}
    assert h.activities()[1].options == {"level": "1"}

    assert env.ok(GetReady).reply.reason == "generated 2 scripts"
    assert h.button is OperatorButton.LOADING
    assert env.log == [
        "activate a {'level': '2'}",
        "generate a",
        "activate b {'level': '1'}",
        "generate b",
    ]
    h.tick(40)
    assert h.button is OperatorButton.START

    start = env.ok(Start)
    assert start.reply.reason == "started 2 activities"
    assert h.button is OperatorButton.STOP
    (push,) = start.effects
    assert isinstance(push, PushScripts)
    assert [e.activity for e in push.entries] == ["a", "b"]
    assert [e.activity for e in push.lifo_order()] == ["b", "a"]
    assert env.states() == [("a", CUR), ("b", NYC)]

    assert h.activity_started("a_script")
    assert h.activity_finished("a_script", completed=True)
    assert env.states() == [("a", DONE), ("b", CUR)]
    assert h.button is OperatorButton.STOP

    stop = env.ok(Stop)
    assert stop.effects == (StopActivities(activitynames=("b_script",)),)
    assert env.states() == [("a", DONE), ("b", NYC)]
    assert h.button is OperatorButton.START

    env.ok(Reorder, "b", position=0)
    assert env.states() == [("b", NYC), ("a", DONE)]

    env.ok(Restart)
    assert env.states() == [("b", NYC), ("a", NYC)]
    assert h.button is OperatorButton.START

    env.log.clear()
    env.ok(Clear)
    assert env.states() == []
    assert env.log == ["shutdown b", "shutdown a"]
    assert h.button is OperatorButton.GET_READY


def test_start_pushes_only_not_yet_completed_activities_in_list_order():
    env = Env()
    env.ready("a", "b", "c")
    env.ok(Start)
    env.h.activity_finished("a", completed=True)
    env.ok(Stop)
    (push,) = env.ok(Start).effects
    assert [e.activity for e in push.entries] == ["b", "c"]
    assert [e.script.activityname for e in push.entries] == ["b_script", "c_script"]
    assert env.states() == [("a", DONE), ("b", CUR), ("c", NYC)]


def test_last_activity_finished_turns_the_button_to_start_and_start_is_then_refused():
    env = Env()
    env.ready("a")
    env.ok(Start)
    env.h.activity_finished("a", completed=True)
    assert env.h.button is OperatorButton.START
    env.refused(Start, match="every activity is completed; press restart first")
    env.ok(Restart)
    assert env.states() == [("a", NYC)]
    env.ok(Start)


def test_activity_finished_without_completing_goes_back_to_not_yet_completed():
    env = Env()
    env.ready("a", "b")
    env.ok(Start)
    env.h.activity_finished("a", completed=False)
    assert env.states() == [("a", NYC), ("b", CUR)]


def test_callbacks_ignore_activities_that_are_not_running():
    env = Env()
    env.ready("a")
    assert not env.h.activity_started("idle_activity")
    assert not env.h.activity_finished("a", completed=True)  # not started
    assert env.states() == [("a", NYC)]


def test_activity_started_marks_the_reported_activity_current():
    env = Env()
    env.ready("a", "b")
    env.ok(Start)
    assert env.h.activity_started("b")
    assert env.states() == [("a", NYC), ("b", CUR)]


def test_state_reports_button_activities_and_replies():
    env = Env()
    reply = env.ok(Add, "a").reply
    state = env.h.state(7, 140, replies=(reply,))
    assert (state.tick, state.time_ms, state.button) == (7, 140, "get_ready")
    assert [a.name for a in state.activities] == ["a"]
    assert state.replies == (reply,)


# ------------------------------------------------------------------ list / add


def test_list_names_the_catalogue_in_any_state():
    env = Env()
    assert env.ok(ListActivities).reply.reason == "available: a, b, c"
    env.ready("a")
    env.ok(Start)
    assert env.ok(ListActivities).reply.ok
    assert [i.name for i in env.h.describe()] == ["a", "b", "c"]


def test_add_refuses_unknown_generators():
    env = Env()
    env.refused(Add, "z", match="unknown generator 'z' (available: a, b, c)")


def test_add_refuses_duplicates():
    env = Env()
    env.ok(Add, "a")
    env.refused(Add, "a", match="'a' is already selected")


def test_add_refuses_bad_options_naming_the_option():
    env = Env()
    env.refused(Add, "a", options={"level": "9"}, match="a: option 'level': 9 is out of range")
    env.refused(Add, "a", options={"speed": "1"}, match="unknown option 'speed'")


def test_add_after_ready_turns_the_button_back_to_get_ready_and_generates_only_the_new_one():
    env = Env()
    env.ready("a")
    env.ok(Add, "b")
    assert env.h.button is OperatorButton.GET_READY
    env.log.clear()
    env.ok(GetReady)
    assert env.log == ["activate b {'level': '1'}", "generate b"]


def test_add_refused_while_loading_and_while_running():
    env = Env()
    env.ok(Add, "a")
    env.ok(GetReady)
    env.refused(Add, "b", match="cannot add while the button shows loading")
    env.h.tick(0)
    env.ok(Start)
    env.refused(Add, "b", match="cannot add while the activities run; stop first")


# --------------------------------------------------------------------- remove


def test_remove_calls_shutdown_and_leaves_the_others():
    env = Env()
    env.ready("a", "b")
    env.log.clear()
    env.ok(Remove, "a")
    assert env.log == ["shutdown a"]
    assert env.states() == [("b", NYC)]
    assert env.h.button is OperatorButton.START


def test_removing_the_only_quiescent_activity_makes_the_button_start():
    env = Env()
    env.ready("a")
    env.ok(Add, "b")
    env.ok(Remove, "b")
    assert env.h.button is OperatorButton.START


def test_removing_the_last_activity_makes_the_button_get_ready():
    env = Env()
    env.ready("a")
    env.ok(Remove, "a")
    assert env.h.button is OperatorButton.GET_READY


def test_remove_refuses_unselected_current_and_queued_activities():
    env = Env()
    env.refused(Remove, "a", match="'a' is not selected")
    env.ready("a", "b", "c")
    env.ok(Start)
    env.refused(Remove, "a", match="'a' is running; stop first")
    env.refused(Remove, "b", match="'b' is queued to run; stop first")


def test_remove_of_a_completed_activity_is_allowed_while_running():
    env = Env()
    env.ready("a", "b")
    env.ok(Start)
    env.h.activity_finished("a", completed=True)
    env.ok(Remove, "a")
    assert env.states() == [("b", CUR)]
    assert env.h.button is OperatorButton.STOP


def test_remove_refused_while_loading():
    env = Env()
    env.ok(Add, "a")
    env.ok(GetReady)
    env.refused(Remove, "a", match="cannot remove while the button shows loading")


# -------------------------------------------------------------------- reorder


def test_reorder_moves_an_activity_to_a_position():
    env = Env()
    for n in "abc":
        env.ok(Add, n)
    env.ok(Reorder, "c", position=0)
    assert [n for n, _ in env.states()] == ["c", "a", "b"]
    env.ok(Reorder, "c", position=2)
    assert [n for n, _ in env.states()] == ["a", "b", "c"]


def test_reorder_refusals():
    env = Env()
    env.ok(Add, "a")
    env.refused(Reorder, "b", position=0, match="'b' is not selected")
    env.refused(Reorder, "a", position=1, match="position 1 is out of range 0..0")
    env.refused(Reorder, "a", position=-1, match="position -1 is out of range")
    env.ok(GetReady)
    env.refused(Reorder, "a", position=0, match="cannot reorder while the button shows loading")
    env.h.tick(0)
    env.ok(Start)
    env.refused(Reorder, "a", position=0, match="cannot reorder while the activities run")


# ------------------------------------------------------------------ get ready


def test_get_ready_refusals_by_button_state():
    env = Env()
    env.refused(GetReady, match="no activities selected; add one first")
    env.ok(Add, "a")
    env.ok(GetReady)
    env.refused(GetReady, match="cannot get ready while the button shows loading")
    env.h.tick(0)
    env.refused(GetReady, match="cannot get ready while the button shows start")
    env.ok(Start)
    env.refused(GetReady, match="cannot get ready while the button shows stop")


def test_get_ready_failure_refuses_the_whole_command_and_leaves_state_intact():
    env = Env(broken={"fail": True})
    env.ok(Add, "a")
    env.ok(Add, "broken")
    result = env.do(GetReady)
    assert not result.reply.ok
    assert result.reply.reason == "broken: cannot see the ball"
    assert env.h.button is OperatorButton.GET_READY
    assert env.states() == [("a", NYC), ("broken", NYC)]
    # the generators activated by the failed command are quiescent again
    assert env.log[-2:] == ["shutdown a", "shutdown broken"]
    env.ok(Remove, "broken")
    env.ok(GetReady)
    env.h.tick(0)
    (push,) = env.ok(Start).effects
    assert [e.activity for e in push.entries] == ["a"]


def test_get_ready_refuses_a_script_that_breaks_the_alfa_rules():
    bad_alfa = RuleMessage(
        rulecode=1, id="r", intopic="", outtopic="", action=RuleAction.A, mutexcmd=MutexCmd.L
    )
    script = msgspec.structs.replace(_script("bad"), alfarulemessages=(bad_alfa,))
    env = Env(bad={"script": script})
    env.ok(Add, "bad")
    result = env.do(GetReady)
    assert not result.reply.ok
    assert result.reply.reason.startswith("bad: generated an invalid script: ")
    assert "alfarulemessages[0].mutexcmd: mutexcmd must be U here, got L" in result.reply.reason
    assert env.h.button is OperatorButton.GET_READY


def test_get_ready_refuses_two_scripts_with_the_same_activityname():
    env = Env(twin={"script": _script("a_script")})
    env.ok(Add, "a")
    env.ok(Add, "twin")
    result = env.do(GetReady)
    assert result.reply.reason == "twin: its script is named 'a_script' like 'a''s"
    assert env.h.button is OperatorButton.GET_READY


def test_loading_lasts_until_the_next_tick_and_replies_count_one_in_the_singular():
    env = Env()
    env.ok(Add, "a")
    assert env.ok(GetReady).reply.reason == "generated 1 script"
    assert env.h.state(1, 20).button == "loading"
    env.h.tick(20)
    assert env.h.state(2, 40).button == "start"
    env.h.tick(40)
    assert env.h.button is OperatorButton.START
    assert env.ok(Start).reply.reason == "started 1 activity"


# --------------------------------------------------------------- start / stop


@pytest.mark.parametrize("button", ["get_ready", "loading", "stop"])
def test_start_refused_unless_the_button_shows_start(button):
    env = Env()
    if button != "get_ready":
        env.ok(Add, "a")
        env.ok(GetReady)
    if button == "stop":
        env.h.tick(0)
        env.ok(Start)
    assert env.h.button.value == button
    env.refused(Start, match=f"cannot start while the button shows {button}")


@pytest.mark.parametrize("button", ["get_ready", "loading", "start"])
def test_stop_refused_unless_running(button):
    env = Env()
    if button != "get_ready":
        env.ok(Add, "a")
        env.ok(GetReady)
    if button == "start":
        env.h.tick(0)
    assert env.h.button.value == button
    env.refused(Stop, match=f"cannot stop: nothing runs (the button shows {button})")


def test_stop_names_the_running_and_queued_scripts_and_keeps_completed_ones():
    env = Env()
    env.ready("a", "b", "c")
    env.ok(Start)
    env.h.activity_finished("a", completed=True)
    (stop,) = env.ok(Stop).effects
    assert stop == StopActivities(activitynames=("b_script", "c_script"))
    assert env.states() == [("a", DONE), ("b", NYC), ("c", NYC)]
    # finished-callbacks after the stop are not ours any more
    assert not env.h.activity_finished("b", completed=True)


# ------------------------------------------------------------ restart / clear


@pytest.mark.parametrize("verb", [Restart, Clear])
def test_restart_and_clear_refused_while_running_or_loading(verb):
    env = Env()
    env.ok(Add, "a")
    env.ok(GetReady)
    env.refused(verb, match=f"cannot {verb.__struct_config__.tag} while the button shows loading")
    env.h.tick(0)
    env.ok(Start)
    env.refused(
        verb, match=f"cannot {verb.__struct_config__.tag} while the activities run; stop first"
    )


def test_restart_and_clear_accepted_with_get_ready():
    env = Env()
    env.ok(Add, "a")
    env.ok(Restart)
    env.ok(Clear)
    assert env.states() == []
    env.ok(Clear)  # clearing an empty list is fine
