"""Skipping rules whose inputs did not change: what conditions read, and that skipping is exact."""

from __future__ import annotations

from typing import Any

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from oimi.pipeline.messages import (
    Camera,
    Human,
    MutexCmd,
    Object,
    Obstacle,
    RuleAction,
    RuleMessage,
    Touch,
    TouchType,
    WorldMap,
)
from oimi.pipeline.think.chain import RuleChain
from oimi.pipeline.think.conditions import compile_condition
from oimi.pipeline.think.functions import (
    TIME,
    FunctionContext,
    FunctionRegistry,
    evaluation,
)
from oimi.pipeline.think.library import BUILTIN_RULES
from oimi.pipeline.think.rules import (
    EVALUATION_BYTES,
    MAX_WAIT,
    Effect,
    Memo,
    Rule,
    RuleContext,
    RuleRegistry,
)
from oimi.pipeline.think.stdlib import default_registry

CALLS: list[str] = []
"""Which counting function ran, in order (cleared by each test that reads it)."""


@evaluation("battery_low_counted", reads=("robotstatus.batterytimeleft",))
def battery_low_counted(ctx: FunctionContext, below_ms: float) -> bool:
    """Counts its calls. Example: ! {E: battery_low_counted (100)}"""
    CALLS.append("declared")
    return ctx.world_map.robotstatus.batterytimeleft < below_ms


@evaluation("battery_low_undeclared")
def battery_low_undeclared(ctx: FunctionContext, below_ms: float) -> bool:
    """Counts its calls; declares no reads. Example: ! {E: battery_low_undeclared (100)}"""
    CALLS.append("undeclared")
    return ctx.world_map.robotstatus.batterytimeleft < below_ms


@evaluation("poke_undeclared")
def poke_undeclared(ctx: FunctionContext, mark: str) -> bool:
    """Marks every person; declares no reads (it may change anything). Example:
    ! {E: poke_undeclared ("1")}"""
    for human in ctx.world_map.humans:
        human.attributes["poked"] = mark
    return False


FUNCTIONS = FunctionRegistry(
    [*default_registry().functions(), battery_low_counted, battery_low_undeclared, poke_undeclared]
)


def _rule(code: int, text: str) -> type[Rule]:
    return type(f"Rule{code}", (Rule,), {"rulecode": code, "condition_text": text})


EXTRA_RULES = (
    _rule(1000, "! {E: battery_low_counted (100)}"),
    _rule(1001, "! {E: battery_low_undeclared (100)}"),
    # scope U and T bindings, released and bound again by the rules around them
    _rule(
        1002,
        "{CLASS #Human U ?pal B: farther_than (1.0)}, {VAR @d T F: distance (?pal)}"
        ' ! {E: var_is (@d, "2.5")}',
    ),
    _rule(1003, "{CLASS #Human T ?near B: closer_than (1.5)} ! {E: lost (?pal)}"),
    _rule(1004, '{ATT ?pal $seen U F: concat ("y")} ! {E: far (?pal, 3.0)}'),
    _rule(1005, "{CLASS #Human L ?pal B: infront ()} ! {E: no_human_in_front ()}"),
    _rule(1006, '{VAR @act L F: current_activity ()} ! {E: var_is (@act, "playroom")}'),
)
REGISTRY = RuleRegistry([*BUILTIN_RULES, *EXTRA_RULES], functions=FUNCTIONS)


def loaded(codes: list[int], *, skip: bool, registry: RuleRegistry = REGISTRY) -> RuleChain:
    chain = RuleChain(registry, shortcuts=skip)
    chain.apply(
        RuleMessage(
            rulecode=code,
            id=f"r{code}",
            intopic="",
            outtopic="",
            action=RuleAction.A,
            mutexcmd=MutexCmd.U,
        )
        for code in codes
    )
    return chain


# ------------------------------------------------------------------ what conditions read


@pytest.mark.parametrize(
    ("text", "reads"),
    [
        ("! {TRUE}", ()),
        ("! {E: camera_offline ()}", ("cameras",)),
        ('! {E: touched ("C")}', (TIME, "robotstatus.touch")),
        (
            "{CLASS #Obstacle L ?o ?THIS>&positionrho OP< 0.45} ! {TRUE}",
            ("aliases", "obstacles", "tick_scope", "variables"),
        ),
        # ?c is a Human once its CLASS clause held: far reads the humans only
        (
            "{CLASS #Human U ?c} ! {E: far (?c, 3.0)}",
            ("aliases", "humans", "tick_scope", "variables"),
        ),
        # an alias no CLASS clause fixed may name an entity of any class
        (
            "! {E: lost (?c)}",
            (
                "aliases",
                "humans",
                "objects",
                "obstacles",
                "robotstatus.activities",
                "tick_scope",
                "variables",
            ),
        ),
    ],
)
def test_a_condition_lists_what_it_reads(text: str, reads: tuple[str, ...]) -> None:
    assert compile_condition(text).reads == tuple(sorted(reads))


def test_a_function_without_reads_makes_its_conditions_read_anything() -> None:
    condition = compile_condition("! {E: battery_low_undeclared (1)}", registry=FUNCTIONS)
    assert condition.reads is None
    assert Memo(condition).paths is None, "never skipped"
    assert condition.binds, "it may write the stores too"


@pytest.mark.parametrize(
    ("text", "binds"),
    [
        ("! {TRUE}", False),
        ("{CLASS #Human L ?c} ! {E: far (?c, 3.0)}", False),
        ('{VAR @v L F: concat ("a")} ! {TRUE}', False),
        ("{CLASS #Human U ?c} ! {TRUE}", True),
        ('{CLASS #Human L ?c}, {ATT ?c $x T F: concat ("1")} ! {TRUE}', True),
    ],
)
def test_a_condition_knows_whether_it_binds_in_the_map_or_the_tick_scope(
    text: str, binds: bool
) -> None:
    """Scope L binds only for the rule: the chain then takes the stores as they were."""
    condition = compile_condition(text)
    assert condition.binds is binds
    assert Memo(condition).binds is binds


def test_a_condition_that_reads_the_clock_is_never_skipped() -> None:
    memo = Memo(compile_condition('! {E: touched ("C")}'))
    assert memo.known and memo.paths is None


def test_a_rule_compares_its_inputs_only_while_that_pays() -> None:
    memo = Memo(compile_condition("{CLASS #Obstacle L ?o ?THIS>&positionrho OP< 0.45} ! {TRUE}"))
    small, large = (None, b"x" * 100), (None, b"x" * (EVALUATION_BYTES // 2))
    assert memo.compared(small, False) is False and memo.wait == 0, "cheap: compared again"
    assert memo.compared(large, True) is True and memo.wait == 0, "found unchanged: it pays"
    for _ in range(8):
        memo.compared(large, False)
    assert memo.wait == MAX_WAIT, "large and changing: evaluated without comparing"


def test_reads_name_fields_of_the_map() -> None:
    with pytest.raises(ValueError, match=r"'robotstatus\.battery' is not 'now_ms' nor a field"):
        evaluation("bad", reads=("robotstatus.battery",))


# ------------------------------------------------------------------ skipping


def battery_map(battery_ms: int) -> WorldMap:
    world = WorldMap()
    world.robotstatus.batterytimeleft = battery_ms
    return world


def test_a_rule_is_skipped_until_what_it_reads_changes() -> None:
    chain = loaded([1000], skip=True)
    world = battery_map(500)
    CALLS.clear()
    first = chain.propagate(world, now_ms=0)
    world.humans.append(Human(id="h", creationtime=0))  # not read by the rule
    second = chain.propagate(world, now_ms=20)
    assert CALLS == ["declared"], "the second pass found the battery as it was"
    assert second == first and not first[0].fired
    world.robotstatus.batterytimeleft = 50
    third = chain.propagate(world, now_ms=40)
    assert CALLS == ["declared", "declared"], "the battery changed: evaluated again"
    assert third[0].fired


def test_a_rule_calling_an_undeclared_function_is_always_evaluated() -> None:
    chain = loaded([1001], skip=True)
    world = battery_map(500)
    CALLS.clear()
    for now_ms in (0, 20, 40):
        chain.propagate(world, now_ms=now_ms)
    assert CALLS == ["undeclared"] * 3


def test_a_rule_that_held_is_evaluated_again() -> None:
    chain = loaded([1000], skip=True)
    world = battery_map(50)
    CALLS.clear()
    chain.propagate(world, now_ms=0)
    chain.propagate(world, now_ms=20)
    assert CALLS == ["declared"] * 2, "its body may read anything: never skipped"


# ------------------------------------------------------------------ exactness

RHOS = (0.5, 0.7, 1.2, 1.8, 2.5, 4.0)
THETAS = (-1.0, 0.0, 0.3, 1.2)

step = st.one_of(
    st.tuples(st.just("move"), st.integers(0, 2), st.sampled_from(RHOS), st.sampled_from(THETAS)),
    st.tuples(st.just("leave"), st.integers(0, 2)),
    st.tuples(st.just("obstacle"), st.sampled_from((0.3, 0.6, 2.0))),
    st.tuples(st.just("toy"), st.sampled_from((0.5, 2.0)), st.booleans()),
    st.tuples(st.just("battery"), st.sampled_from((50, 100_000, 500_000))),
    st.tuples(st.just("camera"), st.booleans()),
    st.tuples(st.just("touch"), st.sampled_from(("C", "H"))),
    st.tuples(st.just("joystick"), st.booleans()),
    st.tuples(st.just("activity"), st.sampled_from(("idle_activity", "playroom", "x"))),
    st.tuples(st.just("forget")),
    st.tuples(st.just("wait"), st.sampled_from((0, 20, 1000, 6000))),
)


def apply(world: WorldMap, change: tuple[Any, ...], now_ms: int) -> None:
    """One change of the map, as sensors, the reader or an operator might make it."""
    kind, *args = change
    status = world.robotstatus
    match kind:
        case "move":
            index, rho, theta = args
            ident = f"h{index}"
            human = next((h for h in world.humans if h.id == ident), None)
            if human is None:
                human = Human(id=ident, creationtime=now_ms)
                world.humans.append(human)
            human.positionrho, human.positiontheta = rho, theta
            human.positionchangetime = now_ms
        case "leave":
            world.humans = [h for h in world.humans if h.id != f"h{args[0]}"]
        case "obstacle":
            world.obstacles = [Obstacle(id="wall", creationtime=0, positionrho=args[0])]
        case "toy":
            world.objects = [
                Object(id="ball", creationtime=0, positionrho=args[0], istarget=args[1])
            ]
        case "battery":
            status.batterytimeleft = args[0]
            status.mark_set("batterytimeleft")
        case "camera":
            world.cameras = [Camera(id="cam", isonline=args[0])]
        case "touch":
            touch = Touch(touchtype=TouchType(args[0]), duration=100, startingtime=now_ms)
            status.touch = [*status.touch[-2:], touch]
        case "joystick":
            status.joystick_engaged = args[0]
            status.joystick_engagedtime = now_ms
        case "activity":
            world.scriptinfo.currentactivity = args[0]
        case "forget":
            world.aliases.clear()


@settings(max_examples=60, deadline=None, derandomize=True)
@given(st.lists(step, max_size=40))
def test_skipping_decides_exactly_as_evaluating_every_rule(changes) -> None:
    codes = [rule.rulecode for rule in (*BUILTIN_RULES, *EXTRA_RULES)]
    skipping, evaluating = loaded(codes, skip=True), loaded(codes, skip=False)
    maps = {skipping: WorldMap(), evaluating: WorldMap()}
    now_ms = 0
    for change in changes:
        if change[0] == "wait":
            now_ms += change[1]
        decided = []
        for chain, world in maps.items():
            apply(world, change, now_ms)
            decided.append(
                (
                    chain.propagate(world, now_ms=now_ms),
                    chain.take_notes(),
                    msgspec.json.encode(world),
                )
            )
        assert decided[0] == decided[1]
        now_ms += 20


class Quiet(Rule):
    """Fires and changes nothing: the people it may change are encoded only if it does."""

    rulecode = 1010
    condition_text = "! {TRUE}"
    writes = ("humans",)
    announces = True


class Tags(Rule):
    rulecode = 1012
    condition_text = "! {TRUE}"
    writes = ("humans",)
    announces = True

    def act(self, world_map: WorldMap, found: object, ctx: RuleContext) -> Effect:
        ctx.changing()
        world_map.humans[0].attributes["tagged"] = "yes"
        return Effect.CHANGED


@pytest.mark.parametrize("skip", [True, False])
def test_a_body_s_changes_count_from_the_last_fired_rule_however_late_it_encodes(skip) -> None:
    """A function declaring no reads changed the map after a rule that fired: the next
    body's changes include it, as when every body's parts are encoded before it runs."""
    rules = RuleRegistry(
        [Quiet, _rule(1011, '! {E: poke_undeclared ("yes")}'), Tags], functions=FUNCTIONS
    )
    chain = loaded([1010, 1011, 1012], skip=skip, registry=rules)
    world = WorldMap(humans=[Human(id="h", creationtime=0)])
    *_, tagged = chain.propagate(world, now_ms=0)
    assert [(c.path, c.new) for c in tagged.changes] == [
        ("humans[0].attributes.poked", '"yes"'),
        ("humans[0].attributes.tagged", '"yes"'),
    ]
