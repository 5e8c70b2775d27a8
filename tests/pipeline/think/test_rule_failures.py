"""A user's rule, function or jump condition that raises: reported, and the session goes on."""

from __future__ import annotations

import msgspec
import pytest
from oimi.pipeline.errors import failure
from oimi.pipeline.events import Level, ProgressKind
from oimi.pipeline.messages import Human, MutexCmd, RuleAction, RuleMessage, WorldMap
from oimi.pipeline.script.dsl import compile_dsl
from oimi.pipeline.think.chain import RuleChain
from oimi.pipeline.think.conditions import compile_condition
from oimi.pipeline.think.functions import FunctionContext, FunctionRegistry, boolean, evaluation
from oimi.pipeline.think.mapparts import mistyped
from oimi.pipeline.think.reader import BlockReader, ScriptEntry
from oimi.pipeline.think.rules import Effect, Rule, RuleRegistry
from oimi.pipeline.think.stdlib import default_registry


@evaluation("answer", reads=("variables",))
def answer(ctx: FunctionContext) -> bool:
    value = ctx.world_map.variables.get("@answer", "yes")
    if value == "raise":
        raise ZeroDivisionError("no answer")
    return {"yes": True, "no": False}.get(value, value)  # type: ignore[return-value]


@boolean("odd", classes=("Human",))
def odd(ctx: FunctionContext, entity: object) -> bool:
    return "odd"  # type: ignore[return-value]


FUNCTIONS = FunctionRegistry([answer, odd, *default_registry().functions()])


class Asks(Rule):
    rulecode = 2001
    condition_text = "! {E: answer ()}"


class Breaks(Rule):
    rulecode = 2002
    writes = ("variables",)

    def act(self, world_map: WorldMap, found: object, ctx: object) -> Effect:
        world_map.variables["@half"] = "done"
        raise RuntimeError("body broke")


class Counts(Rule):
    rulecode = 2003
    writes = ("variables",)

    def act(self, world_map: WorldMap, found: object, ctx: object) -> Effect:
        world_map.variables["@count"] = str(int(world_map.variables.get("@count", "0")) + 1)
        return Effect.CHANGED


def message(code: int, action: RuleAction = RuleAction.A) -> RuleMessage:
    """Rule ``r<code>`` added (or, with another ``action``, moved) by an alfa message."""
    return msgspec.structs.replace(LOAD, rulecode=code, id=f"r{code}", action=action)


LOAD = RuleMessage(
    rulecode=0, id="", intopic="", outtopic="", action=RuleAction.A, mutexcmd=MutexCmd.M
)


class Mistypes(Rule):
    """Leaves a text where the map holds a number, and an object no encoder takes."""

    rulecode = 2004

    def act(self, world_map: WorldMap, found: object, ctx: object) -> Effect:
        world_map.variables["@seen"] = "yes"
        rho = world_map.variables.get("@rho")
        world_map.humans[0].positionrho = float(rho) if rho else "far"  # type: ignore[assignment]
        if "@object" in world_map.variables:
            world_map.variables["@thing"] = object()  # type: ignore[assignment]
        return Effect.CHANGED


class Unannounced(Rule):
    """Announces its changes, but changes the map without saying so first."""

    rulecode = 2005
    writes = ("variables",)
    announces = True

    def act(self, world_map: WorldMap, found: object, ctx: object) -> Effect:
        world_map.variables["@said"] = "no"
        return Effect.CHANGED


def chain_of(*codes: int) -> RuleChain:
    rules = [Asks, Breaks, Counts, Mistypes, Unannounced]
    chain = RuleChain(RuleRegistry(rules, functions=FUNCTIONS))
    assert chain.apply([message(code) for code in codes]) == []
    return chain


def test_a_body_that_raises_is_removed_reported_and_the_next_rule_still_runs() -> None:
    chain, world = chain_of(2002, 2003), WorldMap()
    decisions = chain.propagate(world, now_ms=0)
    assert [d.rule for d in decisions] == ["r2003"], "the map went on to the next rule"
    assert world.variables == {"@half": "done", "@count": "1"}, "what it did before stays"
    [report] = chain.take_failures()
    assert report.level == Level.ERROR and report.ref == "r2002"
    line = Breaks.act.__code__.co_firstlineno + 2
    assert report.message == (
        "rule 'r2002' (code 2002) raised RuntimeError: body broke"
        f" (test_rule_failures.py:{line}); removed"
    )
    assert chain.names() == (("r2003",), (), ("r2002",)) and chain.take_failures() == []
    chain.propagate(world, now_ms=20)
    assert world.variables["@count"] == "2" and chain.take_failures() == []


def test_a_body_that_announces_its_changes_but_did_not_is_removed() -> None:
    chain, world = chain_of(2005), WorldMap()
    assert chain.propagate(world, now_ms=0) == []
    [report] = chain.take_failures()
    assert "Unannounced.act changed the map without ctx.changing()" in report.message
    assert chain.names() == ((), (), ("r2005",))


def test_a_removed_failing_rule_comes_back_with_c() -> None:
    chain = chain_of(2002)
    chain.propagate(WorldMap(), now_ms=0)
    assert chain.apply([message(2002, RuleAction.C)]) == [] and chain.state("r2002") == "active"


@pytest.mark.parametrize(
    ("answer_is", "reported"),
    [
        ("raise", "ZeroDivisionError: no answer (test_rule_failures.py:"),
        (
            "maybe",
            "TypeError: answer returned 'maybe', not True or False"
            " (in answer, test_rule_failures.py:20); removed",
        ),
    ],
)
def test_a_condition_whose_function_raises_or_answers_wrongly_removes_the_rule(
    answer_is: str, reported: str
) -> None:
    chain, world = chain_of(2001), WorldMap()
    world.variables["@answer"] = answer_is
    assert chain.propagate(world, now_ms=0) == []
    [report] = chain.take_failures()
    assert reported in report.message and chain.state("r2001") == "removed"


def test_a_function_answering_true_or_false_is_not_a_failure() -> None:
    chain, world = chain_of(2001), WorldMap()
    for value, fired in (("yes", True), ("no", False)):
        world.variables["@answer"] = value
        [decision] = chain.propagate(world, now_ms=0)
        assert decision.fired is fired and chain.take_failures() == []


def test_a_boolean_criterion_answering_a_str_is_a_type_error_naming_it_and_its_place() -> None:
    condition = compile_condition("{CLASS #Human L ?h B: odd ()} ! {TRUE}", registry=FUNCTIONS)
    world = WorldMap()
    world.humans.append(Human(id="h1", creationtime=0))
    wrong = r"^odd returned 'odd', not True or False \(in odd, test_rule_failures.py:28\)$"
    with pytest.raises(TypeError, match=wrong):
        condition.evaluate(world, now_ms=0)


def test_failure_names_the_innermost_frame_outside_the_pipeline() -> None:
    try:
        compile_condition("! {E: answer ()}", registry=FUNCTIONS).evaluate(
            WorldMap(variables={"@answer": "raise"}), now_ms=0
        )
    except ZeroDivisionError as error:
        line = answer.__code__.co_firstlineno + 4  # the decorator's line first
        assert failure(error) == f"ZeroDivisionError: no answer (test_rule_failures.py:{line})"
    assert failure(KeyError()) == "KeyError", "no traceback: no place"


ASKS = """[asks]
[goal:g]
[action]
[b#ask#blk_jump: CND(! {E: answer ()}) TRJMP(yes) FLSJMP()]
[b#no#blk_inst: MV() LD("0.3, 0.7, 1, 1, 0, 100") AO()]
[b#yes#blk_inst: MV() LD("1, 1, 1, 1, 0, 100") AO()]
"""


def test_a_jump_condition_that_raises_is_taken_as_false_and_logged() -> None:
    asks = ScriptEntry(activity="asks", script=compile_dsl(ASKS, source="asks.txt"), source="x")
    world = WorldMap(variables={"@answer": "raise"})
    r = BlockReader(world, idle=asks, resolve=lambda name: None, functions=FUNCTIONS)
    out = r.start(now_ms=0)
    out.extend(r.read(actuator_done=True, now_ms=0))
    assert [i.detail for i in out.items if i.kind == ProgressKind.JUMP] == ["False -> next"]
    assert world.scriptinfo.blockid == "blk1", "the false branch: the next block"
    [log] = [e for e in out.logs if e.level == Level.ERROR]
    assert log.source == "reader" and log.ref == "asks"
    assert log.message.startswith(
        "asks/goal0/act0/blk0: the jump condition raised ZeroDivisionError: no answer"
    )
    assert log.message.endswith("; taken as false")


def test_failure_masks_memory_addresses() -> None:
    thing = object()
    assert failure(ValueError(f"bad {thing!r}")) == "ValueError: bad <object object at 0x…>"


@pytest.mark.parametrize(
    ("variables", "said"),
    [
        ({}, "humans[0].positionrho: Expected `float`, got `str`"),
        (
            {"@rho": "1.5", "@object": "1"},
            "variables: Encoding objects of type object is unsupported",
        ),
    ],
    ids=["mistyped", "unencodable"],
)
def test_a_body_that_leaves_the_map_mistyped_is_undone_and_removed(
    variables: dict[str, str], said: str
) -> None:
    """A text where the safety supervisor reads a number would stop the session: the parts
    the body changed are put back (in place) before the map goes on."""
    chain, world = chain_of(2004, 2003), WorldMap(variables=dict(variables))
    world.humans.append(Human(id="h1", creationtime=0, positionrho=0.7))
    humans, kept = world.humans, world.variables
    decisions = chain.propagate(world, now_ms=0)
    assert [d.rule for d in decisions] == ["r2003"]
    assert world.humans is humans and world.humans[0].positionrho == 0.7
    assert world.variables is kept and "@seen" not in kept and "@thing" not in kept
    assert kept["@count"] == "1", "the next rule saw the map as it was"
    [report] = chain.take_failures()
    undone = "the body's changes are undone; removed"
    assert report.message == f"rule 'r2004' (code 2004) raised TypeError: {said}; {undone}"


def test_mistyped_names_the_first_place_whose_value_is_not_of_its_type() -> None:
    world = WorldMap()
    world.humans.append(Human(id="h1", creationtime=0, positionrho=0.7))
    assert mistyped(world) == ""
    world.humans[0].positionrho = "near"  # type: ignore[assignment]
    assert mistyped(world) == "humans[0].positionrho: Expected `float`, got `str`"
    world.robotstatus.batterytimeleft = 1.5  # type: ignore[assignment]
    assert mistyped(world) == "robotstatus.batterytimeleft: Expected `int`, got `float`"
    world.robotstatus = None  # type: ignore[assignment]
    assert mistyped(world) == "robotstatus: Expected `object`, got `None`"
