"""The function registry and the standard functions of the rule language."""

from __future__ import annotations

import re

import pytest
from oimi.pipeline.messages import (
    ActivityTracking,
    GoalStatus,
    GoalTracking,
    Human,
    Object,
    Pose,
    RobotStatus,
    ScriptInfo,
    Touch,
    WorldMap,
)
from oimi.pipeline.think import stdlib
from oimi.pipeline.think.conditions import compile_condition
from oimi.pipeline.think.errors import RuleSyntaxError
from oimi.pipeline.think.functions import (
    ArgKind,
    Bound,
    Family,
    FunctionContext,
    FunctionRegistry,
    boolean,
    evaluation,
    string,
)
from oimi.pipeline.think.stdlib import default_registry


def _true(text: str, world: WorldMap, now_ms: int = 10_000) -> bool:
    return compile_condition(text).evaluate(world, now_ms=now_ms, tick_scope={}).result


def _kid(**kw) -> Human:
    return Human(**{"id": "c1", "creationtime": 0, **kw})


# ---------------------------------------------------------------------------- registry


def test_default_registry_holds_the_whole_stdlib_once():
    registry = default_registry()
    assert registry is default_registry()
    assert set(registry.names(Family.B)) == {
        "infront", "closer_than", "farther_than", "has_attribute", "attribute_is",
        "seen_within", "tracked_for", "is_target", "activity_is",
    }  # fmt: skip
    assert set(registry.names(Family.F)) == {
        "attribute", "distance", "bearing", "concat", "now", "current_activity",
    }  # fmt: skip
    assert {"near", "far", "attention_low", "touched", "no_human_in_front", "battery_below",
            "goal_is", "elapsed_over", "var_is", "joystick_engaged", "equals"} <= set(
        registry.names(Family.E)
    )  # fmt: skip


def test_arity_and_kinds_come_from_the_signature():
    registry = default_registry()
    touched = registry.get("touched")
    assert (touched.min_args, touched.max_args) == (1, 2)
    assert touched.kinds == (ArgKind.TEXT, ArgKind.NUMBER)
    concat = registry.get("concat")
    assert (concat.min_args, concat.max_args, concat.kind(5)) == (1, None, ArgKind.TEXT)
    assert registry.get("near").kind(0) is ArgKind.ENTITY
    assert registry.get("lost").kind(0) is ArgKind.OPTIONAL_ENTITY
    assert registry.get("infront").signature == "infront (max_angle_rad=0.5)"


def test_own_registry_extends_the_stdlib_and_changes_the_version():
    @evaluation("audio_playing")
    def audio_playing(ctx: FunctionContext) -> bool:
        return bool(ctx.world_map.robotstatus.audioout)

    base = FunctionRegistry.from_module(stdlib)
    registry = FunctionRegistry([*base.functions(), audio_playing])
    assert registry.version != base.version
    assert base.version == default_registry().version
    compile_condition("! {E: audio_playing ()}", registry=registry)
    with pytest.raises(RuleSyntaxError, match="unknown function 'audio_playing'"):
        compile_condition("! {E: audio_playing ()}")


def test_varargs_function_accepts_any_count_above_its_minimum():
    @string("join")
    def join(ctx: FunctionContext, *parts: str) -> str:
        return "-".join(parts)

    registry = FunctionRegistry([join])
    condition = compile_condition('{VAR @j L F: join ("a", 1, "c")} !', registry=registry)
    assert condition.evaluate(WorldMap(), now_ms=0).bindings == {"@j": "a-1-c"}
    compile_condition("{VAR @j L F: join ()} !", registry=registry)


def test_registering_a_name_twice_is_refused():
    @evaluation("x")
    def one(ctx: FunctionContext) -> bool:
        return True

    @string("x")
    def two(ctx: FunctionContext) -> str:
        return ""

    with pytest.raises(ValueError, match="'x' registered twice"):
        FunctionRegistry([one, two])


def test_unmarked_function_and_unknown_class_are_refused():
    def plain(ctx: FunctionContext) -> bool:
        return True

    with pytest.raises(ValueError, match="not marked"):
        FunctionRegistry([plain])
    with pytest.raises(ValueError, match="unknown classes"):
        boolean("b", classes=("Robot",))


def test_b_function_limited_to_a_class_is_refused_on_others_at_load():
    @boolean("tall", classes=("Human",))
    def tall(ctx: FunctionContext, entity: Bound) -> bool:
        return True

    registry = FunctionRegistry([tall])
    compile_condition("{CLASS #Human L ?h B: tall ()} !", registry=registry)
    with pytest.raises(RuleSyntaxError, match=r"'tall' does not apply to #Object \(only #Human\)"):
        compile_condition("{CLASS #Object L ?h B: tall ()} !", registry=registry)


def test_every_stdlib_docstring_example_compiles():
    examples = []
    for spec in default_registry():
        found = re.findall(r"^Example: (.+)$", spec.doc, flags=re.MULTILINE)
        assert len(found) == 1, f"{spec.name} has no Example: line"
        examples.append(found[0])
    for text in examples:
        compile_condition(text)


# --------------------------------------------------------------------------- family B


@pytest.mark.parametrize(
    ("criterion", "human", "expected"),
    [
        ("B: infront ()", {"positiontheta": 0.4}, True),
        ("B: infront ()", {"positiontheta": -0.6}, False),
        ("B: infront (0.7)", {"positiontheta": -0.6}, True),
        ("B: closer_than (1)", {"positionrho": 0.9}, True),
        ("B: closer_than (1)", {"positionrho": 1.0}, False),
        ("B: farther_than (1)", {"positionrho": 1.1}, True),
        ("B: farther_than (1)", {"positionrho": 0.5}, False),
        ('B: has_attribute ("name")', {"attributes": {"name": "Ada"}}, True),
        ('B: has_attribute ("name")', {}, False),
        ('B: attribute_is ("role", "child")', {"attributes": {"role": "child"}}, True),
        ('B: attribute_is ("role", "child")', {"attributes": {"role": "adult"}}, False),
        ("B: seen_within (500)", {"positionchangetime": 9600}, True),
        ("B: seen_within (500)", {"positionchangetime": 9400}, False),
        ("B: tracked_for (2000)", {"permanencetime": 2000}, True),
        ("B: tracked_for (2000)", {"permanencetime": 1999}, False),
    ],
)
def test_boolean_functions_on_humans(criterion, human, expected):
    world = WorldMap(humans=[_kid(**human)])
    assert _true(f"{{CLASS #Human L ?c {criterion}}} !", world) is expected


def test_is_target_and_activity_is():
    world = WorldMap(
        objects=[
            Object(id="cube", creationtime=0),
            Object(id="ball", creationtime=5, istarget=True),
        ],
        robotstatus=RobotStatus(activities=[ActivityTracking(activityname="a", status="running")]),
    )
    result = compile_condition("{CLASS #Object L ?o B: is_target ()} !").evaluate(world, now_ms=0)
    assert result.bindings == {"?o": "Object/ball"}
    assert _true('{CLASS #Activity L ?a B: activity_is ("running")} !', world) is True
    assert _true('{CLASS #Activity L ?a B: activity_is ("completed")} !', world) is False


# --------------------------------------------------------------------------- family F


def test_string_functions_give_texts():
    world = WorldMap(
        humans=[_kid(positionrho=1.5, positiontheta=-0.25, attributes={"name": "Ada"})],
        scriptinfo=ScriptInfo(currentactivity="greet"),
    )
    text = (
        '{CLASS #Human L ?c}, {VAR @n L F: attribute (?c, "name")}, {VAR @d L F: distance (?c)},'
        ' {VAR @b L F: bearing (?c)}, {VAR @g L F: concat ("hi ", @n, "!")}, {VAR @t L F: now ()},'
        " {VAR @a L F: current_activity ()} !"
    )
    bindings = compile_condition(text).evaluate(world, now_ms=42).bindings
    assert bindings == {
        "?c": "Human/c1", "@n": "Ada", "@d": "1.5", "@b": "-0.25", "@g": "hi Ada!",
        "@t": "42", "@a": "greet",
    }  # fmt: skip


def test_missing_attribute_fails_the_var_assignment():
    world = WorldMap(humans=[_kid()])
    assert _true('{CLASS #Human L ?c}, {VAR @n L F: attribute (?c, "name")} !', world) is False


# --------------------------------------------------------------------------- family E


def test_near_and_far():
    world = WorldMap(humans=[_kid(positionrho=1.0)])
    assert _true("{CLASS #Human L ?c} ! {E: near (?c, 1.5)}", world) is True
    assert _true("{CLASS #Human L ?c} ! {E: near (?c, 0.5)}", world) is False
    assert _true("{CLASS #Human L ?c} ! {E: far (?c, 0.5)}", world) is True
    assert _true("{CLASS #Human L ?c} ! {E: far (?c, 1.5)}", world) is False


@pytest.mark.parametrize(
    ("human", "window", "expected"),
    [
        ({"positiontheta": 1.0, "positionchangetime": 9000}, 3000, True),
        ({"positiontheta": 0.1, "positionchangetime": 9000}, 3000, False),
        (
            {"positiontheta": 1.0, "positionchangetime": 9000,
             "poses": [Pose(positionrho=1, positiontheta=0.0, positionchangetime=8000)]},
            3000,
            False,
        ),
        (
            {"positiontheta": 1.0, "positionchangetime": 9000,
             "poses": [Pose(positionrho=1, positiontheta=0.0, positionchangetime=6000)]},
            3000,
            True,
        ),
        ({"positiontheta": 1.0, "creationtime": 8000}, 3000, False),
    ],
)  # fmt: skip
def test_attention_low_looks_at_the_window(human, window, expected):
    world = WorldMap(humans=[_kid(**human)])
    text = f"{{CLASS #Human L ?c}} ! {{E: attention_low (?c, {window})}}"
    assert _true(text, world, now_ms=10_000) is expected


def test_touched_needs_the_type_within_the_window():
    touches = [Touch(touchtype="C", duration=200, startingtime=9500)]
    world = WorldMap(robotstatus=RobotStatus(touch=touches))
    assert _true('! {E: touched ("C")}', world) is True
    assert _true('! {E: touched ("H")}', world) is False
    assert _true('! {E: touched ("C", 300)}', world) is False


def test_no_human_in_front():
    world = WorldMap(humans=[_kid(positiontheta=1.0)])
    assert _true("! {E: no_human_in_front ()}", world) is True
    assert _true("! {E: no_human_in_front (1.2)}", world) is False


def test_robot_status_evaluations():
    world = WorldMap(
        robotstatus=RobotStatus(
            batterytimeleft=1000,
            elapsedtime=5000,
            joystick_engaged=True,
            setfields=["batterytimeleft", "elapsedtime"],
        )
    )
    assert _true("! {E: battery_below (1001)}", world) is True
    assert _true("! {E: battery_below (1000)}", world) is False
    assert _true("! {E: elapsed_over (4999)}", world) is True
    assert _true("! {E: elapsed_over (5000)}", world) is False
    assert _true("! {E: joystick_engaged ()}", world) is True
    assert _true("! {E: joystick_engaged ()}", WorldMap()) is False


def test_a_condition_on_an_unknown_robot_status_value_is_false():
    """Issue 16 ruling on thesis 4.3: an attribute never updated is unknown, and a condition
    on an unknown value is false (a map whose battery was never read is not "below")."""
    unknown = WorldMap(robotstatus=RobotStatus(batterytimeleft=0, elapsedtime=0))
    assert _true("! {E: battery_below (120000)}", unknown) is False
    assert _true("! {E: elapsed_over (-1)}", unknown) is False
    known = WorldMap(robotstatus=RobotStatus(setfields=["batterytimeleft"]))
    assert _true("! {E: battery_below (120000)}", known) is True


def test_goal_is_prefers_the_running_activity():
    def act(name, status):
        return ActivityTracking(activityname=name, goals=[GoalTracking(goalid="g", status=status)])

    world = WorldMap(
        scriptinfo=ScriptInfo(currentactivity="now"),
        robotstatus=RobotStatus(
            activities=[act("before", GoalStatus.FAILED), act("now", GoalStatus.REACHED)]
        ),
    )
    assert _true('! {E: goal_is ("g", "reached")}', world) is True
    assert _true('! {E: goal_is ("g", "failed")}', world) is False
    assert _true('! {E: goal_is ("other", "reached")}', world) is False


def test_value_comparisons():
    world = WorldMap(variables={"@v": "2.0", "@w": "abc"})
    assert _true('! {E: var_is (@w, "abc")}', world) is True
    assert _true('! {E: var_is (@unset, "abc")}', world) is False
    assert _true("! {E: equals (@v, 2)}", world) is True
    assert _true('! {E: equals (@w, "abd")}', world) is False
    assert _true('! {E: differs (@w, "abd")}', world) is True
    assert _true("! {E: less_than (@v, 3)}", world) is True
    assert _true("! {E: greater_than (@v, 3)}", world) is False
    assert _true("! {E: less_than (@w, 3)}", world) is False


def test_touched_names_a_touch_type_in_either_case():
    """Thesis table 4.1: touch is {"touchtype": char, ...}; c and C are one type."""
    world = WorldMap(
        robotstatus=RobotStatus(touch=[Touch(touchtype="C", duration=1, startingtime=9_900)])
    )
    assert _true('! {E: touched ("c")}', world) is True
    assert _true('! {E: touched ("h")}', world) is False
