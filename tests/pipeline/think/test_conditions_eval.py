"""Evaluation of compiled rule conditions: scopes, tie-breaks, casting, short-circuits."""

from __future__ import annotations

import msgspec
import pytest
from oimi.pipeline.messages import (
    ActivityTracking,
    Human,
    Object,
    Obstacle,
    RobotStatus,
    WorldMap,
)
from oimi.pipeline.think import condition_parse
from oimi.pipeline.think.conditions import Evaluation, compile_condition, release_alias
from oimi.pipeline.think.errors import RuleSyntaxError
from oimi.pipeline.think.functions import (
    FunctionContext,
    FunctionRegistry,
    evaluation,
    string,
)
from oimi.pipeline.think.stdlib import default_registry


def _map(*humans: Human, **fields) -> WorldMap:
    return WorldMap(humans=list(humans), **fields)


def _human(hid: str, *, age_ms: int = 0, rho: float = 1.0, theta: float = 0.0, **kw) -> Human:
    return Human(id=hid, creationtime=age_ms, positionrho=rho, positiontheta=theta, **kw)


def _eval(text: str, world_map: WorldMap, *, now_ms: int = 10_000, tick=None, registry=None):
    return compile_condition(text, registry=registry).evaluate(
        world_map, now_ms=now_ms, tick_scope=tick
    )


# -------------------------------------------------------------------------- scopes


def test_scope_u_alias_is_kept_in_the_map():
    world = _map(_human("c1"))
    result = _eval("{CLASS #Human U ?child} ! {TRUE}", world)
    assert result == Evaluation(result=True, bindings={"?child": "Human/c1"})
    assert world.aliases == {"?child": "Human/c1"}


def test_scope_t_alias_goes_to_the_tick_dict_only():
    world, tick = _map(_human("c1")), {}
    result = _eval("{CLASS #Human T ?child} !", world, tick=tick)
    assert result.bindings == {"?child": "Human/c1"}
    assert tick == {"?child": "Human/c1"}
    assert world.aliases == {}


def test_scope_l_alias_is_only_in_the_bindings():
    world, tick = _map(_human("c1")), {}
    result = _eval("{CLASS #Human L ?child} !", world, tick=tick)
    assert result.bindings == {"?child": "Human/c1"}
    assert tick == {} and world.aliases == {} and world.variables == {}


def test_t_alias_from_an_earlier_rule_of_the_tick_is_seen_by_the_next():
    world, tick = _map(_human("c1"), _human("c2", age_ms=5)), {}
    _eval("{CLASS #Human T ?child} !", world, tick=tick)
    later = _eval("! {E: near (?child, 2)}", world, tick=tick)
    assert later.result is True
    assert _eval("! {E: near (?child, 2)}", world, tick={}).result is False


def test_variables_are_stored_by_scope_with_their_sigil():
    world, tick = _map(), {}
    text = (
        '{VAR @u U F: concat ("a")}, {VAR @t T F: concat ("b")}, {VAR @l L F: concat ("c")} !'
        ' {E: var_is (@l, "c")}'
    )
    result = _eval(text, world, tick=tick)
    assert result.result is True
    assert list(result.bindings.items()) == [("@u", "a"), ("@t", "b"), ("@l", "c")]
    assert world.variables == {"@u": "a"}
    assert tick == {"@t": "b"}


def test_u_variable_survives_to_the_next_evaluation():
    world = _map()
    _eval("{VAR @started U F: now ()} !", world, now_ms=1234)
    assert _eval('! {E: var_is (@started, "1234")}', world, now_ms=9999).result is True


def test_attribute_is_bound_to_the_alias_and_read_back():
    world = _map(_human("c1", rho=0.75))
    text = (
        "{CLASS #Human U ?c}, {ATT ?c $d U F: distance (?c)},"
        " {CLASS #Human L ?other ?THIS>&positionrho OP< ?c>$d} ! {E: equals (?c>$d, 0.75)}"
    )
    result = _eval(text, world)
    # ?other cannot take c1 (already ?c), so the assignment fails
    assert result.result is False
    assert result.bindings == {"?c": "Human/c1", "?c$d": "0.75"}
    assert world.variables == {"?c$d": "0.75"}
    assert _eval("! {E: equals (?c>$d, 0.75)}", world).result is True


def test_attribute_falls_back_to_the_entity_attributes():
    world = _map(_human("c1", attributes={"name": "Ada"}))
    text = '{CLASS #Human L ?c} ! {E: equals (?c>$name, "Ada")}'
    assert _eval(text, world).result is True
    assert _eval('{CLASS #Human L ?c} ! {E: equals (?c>$age, "3")}', world).result is False


def test_att_on_an_unbound_alias_fails_the_assignment():
    world = _map()
    result = _eval('{ATT ?ghost $x U F: concat ("1")} ! {TRUE}', world)
    assert result == Evaluation(result=False, bindings={})
    assert world.variables == {}


def test_release_alias_removes_it_with_its_attributes():
    world, tick = _map(_human("c1")), {}
    _eval('{CLASS #Human U ?c}, {ATT ?c $x U F: concat ("1")}, {VAR @v U F: now ()} !', world)
    tick["?c$y"] = "2"
    release_alias(world, "?c", tick)
    assert world.aliases == {} and world.variables == {"@v": "10000"} and tick == {}


# ------------------------------------------------------------------- choosing entities


def test_the_oldest_matching_entity_wins():
    world = _map(_human("young", age_ms=500), _human("old", age_ms=100), _human("mid", age_ms=300))
    assert _eval("{CLASS #Human L ?c} !", world).bindings == {"?c": "Human/old"}


def test_equal_ages_are_broken_by_list_order():
    world = _map(_human("first", age_ms=100), _human("second", age_ms=100))
    assert _eval("{CLASS #Human L ?c} !", world).bindings == {"?c": "Human/first"}


def test_only_entities_meeting_every_criterion_are_eligible():
    world = _map(
        _human("old_far", age_ms=1, rho=3.0),
        _human("old_side", age_ms=2, rho=1.0, theta=1.2),
        _human("young_ok", age_ms=9, rho=1.0, theta=0.1),
    )
    text = "{CLASS #Human L ?c ?THIS>&positionrho OP< 1.5, B: infront ()} !"
    assert _eval(text, world).bindings == {"?c": "Human/young_ok"}


@pytest.mark.parametrize("alias", ["?1child", "?my-child", "?niño", "?child.2", "?kid's"])
def test_an_alias_may_be_any_name_without_a_space_or_a_slash(alias):
    """Thesis 4.3: "ID can be any string without ' ' / '/' chars, defined by the user"."""
    world = _map(_human("c1", rho=1.0))
    text = (
        f"{{CLASS #Human U {alias}}}, {{ATT {alias} $my-mood L F: concat (calm)}},"
        f" {{VAR @v.2 L F: concat ({alias}>$my-mood)}} ! {{E: near ({alias}, 2)}}"
    )
    result = _eval(text, world)
    assert result.result is True
    assert result.bindings == {alias: "Human/c1", f"{alias}$my-mood": "calm", "@v.2": "calm"}


def test_one_alias_per_entity_within_a_condition():
    world = _map(_human("a", age_ms=1), _human("b", age_ms=2))
    result = _eval("{CLASS #Human L ?x}, {CLASS #Human L ?y} !", world)
    assert result.bindings == {"?x": "Human/a", "?y": "Human/b"}
    assert (
        _eval("{CLASS #Human L ?x}, {CLASS #Human L ?y}, {CLASS #Human L ?z} !", world).result
        is False
    )


def test_entity_bound_by_another_rule_is_not_eligible():
    world = _map(_human("a", age_ms=1), _human("b", age_ms=2))
    world.aliases["?leader"] = "Human/a"
    assert _eval("{CLASS #Human U ?c} !", world).bindings == {"?c": "Human/b"}
    tick = {"?t": "Human/b"}
    assert _eval("{CLASS #Human L ?d} !", world, tick=tick).result is False


def test_existing_binding_is_kept_while_it_still_meets_the_criteria():
    world = _map(_human("b", age_ms=50, rho=1.0))
    _eval("{CLASS #Human U ?c ?THIS>&positionrho OP< 2} !", world)
    world.humans.insert(0, _human("older", age_ms=1, rho=1.0))
    result = _eval("{CLASS #Human U ?c ?THIS>&positionrho OP< 2} !", world)
    assert result.bindings == {"?c": "Human/b"}


def test_a_bound_alias_stays_with_its_entity_when_it_no_longer_qualifies():
    """Thesis 4.3: once bound, a U alias stays with its entity "until the current Script
    remains in execution or a Rule removes it"; the clause fails while it does not qualify."""
    world = _map(_human("b", age_ms=50, rho=1.0), _human("d", age_ms=60, rho=1.0))
    _eval("{CLASS #Human U ?c ?THIS>&positionrho OP< 2}, {ATT ?c $k U F: now ()} !", world)
    assert world.aliases == {"?c": "Human/b"} and "?c$k" in world.variables
    world.humans[0].positionrho = 5.0
    result = _eval("{CLASS #Human U ?c ?THIS>&positionrho OP< 2} !", world)
    assert result.result is False, "d qualifies, but ?c is b's"
    assert world.aliases == {"?c": "Human/b"} and "?c$k" in world.variables
    world.humans[0].positionrho = 1.5
    result = _eval("{CLASS #Human U ?c ?THIS>&positionrho OP< 2} !", world)
    assert result.result is True and result.bindings == {"?c": "Human/b"}


def test_a_bound_alias_asked_for_another_class_fails():
    world = _map(_human("b"))
    world.objects.append(Object(id="ball", creationtime=0))
    _eval("{CLASS #Human U ?x} !", world)
    assert _eval("{CLASS #Object U ?x} !", world).result is False
    assert world.aliases == {"?x": "Human/b"}


def test_a_scope_t_alias_holds_for_the_rest_of_the_tick():
    world, tick = _map(_human("a", rho=1.0), _human("b", age_ms=5, rho=1.0)), {}
    assert _eval("{CLASS #Human T ?c} !", world, tick=tick).bindings == {"?c": "Human/a"}
    assert _eval("{CLASS #Human T ?c B: infront (0.05)} !", world, tick=tick).result is True
    world.humans[0].positiontheta = 1.0  # a is aside now; b, in front, would qualify
    assert _eval("{CLASS #Human T ?c B: infront (0.05)} !", world, tick=tick).result is False
    assert tick == {"?c": "Human/a"}
    assert _eval("{CLASS #Human T ?c B: infront (0.05)} !", world, tick={}).bindings == {
        "?c": "Human/b"
    }, "the next tick chooses again"


def test_binding_is_rechosen_when_its_entity_left_the_map():
    world = _map(_human("b", age_ms=50))
    _eval("{CLASS #Human U ?c} !", world)
    world.humans[:] = [_human("e", age_ms=70)]
    assert _eval("{CLASS #Human U ?c} !", world).bindings == {"?c": "Human/e"}
    world.humans.clear()
    assert _eval("{CLASS #Human U ?c} !", world).result is False
    assert world.aliases == {}


def test_a_scope_l_clause_never_releases_another_rules_u_alias_of_the_same_name():
    """Thesis 4.3: a U alias lasts "until the current Script remains in execution or a Rule
    removes it"; an L alias only "until the Rule ... has passed the map". The idle activity's
    kick_starter (L ?child, a child in front within 2 m) found child_left's U ?child (a child
    far away) failing its criteria and released it on every pass."""
    world = _map(_human("far", rho=4.0), _human("near", age_ms=5, rho=1.0, theta=0.1))
    child_left = "{CLASS #Human U ?child} ! {E: far (?child, 3.0)}"
    kick_starter = "{CLASS #Human L ?child B: infront (), B: closer_than (2.0)} ! {TRUE}"
    assert _eval(child_left, world).result is True
    assert world.aliases == {"?child": "Human/far"}
    assert _eval(kick_starter, world).bindings == {"?child": "Human/near"}
    assert world.aliases == {"?child": "Human/far"}, "the U alias is child_left's"
    assert _eval(child_left, world).bindings == {"?child": "Human/far"}
    world.humans.pop()  # nobody in front: kick_starter fails, child_left's alias stays
    assert _eval(kick_starter, world).result is False
    assert world.aliases == {"?child": "Human/far"}


def test_an_alias_bound_by_this_evaluation_wins_over_one_of_another_scope():
    world, tick = _map(_human("a", rho=1.0), _human("b", age_ms=5, rho=5.0)), {}
    world.aliases["?c"] = "Human/b"  # a U binding of another rule
    result = _eval(
        "{CLASS #Human T ?c ?THIS>&positionrho OP< 2} ! {E: near (?c, 2)}", world, tick=tick
    )
    assert result.result is True and tick == {"?c": "Human/a"}
    assert world.aliases == {"?c": "Human/b"}


def test_classes_read_their_own_lists():
    world = WorldMap(
        obstacles=[Obstacle(id="wall", creationtime=0, positionrho=0.3)],
        objects=[Object(id="ball", creationtime=0, istarget=True, category="ball")],
        robotstatus=RobotStatus(
            activities=[ActivityTracking(activityname="greet", status="running")]
        ),
    )
    text = (
        '{CLASS #Obstacle L ?w ?THIS>&isfixed OP= "true"},'
        ' {CLASS #Object L ?o ?THIS>&category OP= "ball", B: is_target ()},'
        ' {CLASS #Activity L ?a B: activity_is ("running")} !'
    )
    result = _eval(text, world)
    assert result.bindings == {"?w": "Obstacle/wall", "?o": "Object/ball", "?a": "Activity/greet"}
    assert result.entity(world, "?a") is world.robotstatus.activities[0]
    assert result.entity(world, "?o") is world.objects[0]
    assert result.entity(world, "?nobody") is None


# ------------------------------------------------------------ order and short-circuits


def _recording_registry(calls: list[str]) -> FunctionRegistry:
    @evaluation("mark")
    def mark(ctx: FunctionContext, label: str, outcome: float = 1) -> bool:
        calls.append(label)
        return bool(outcome)

    @evaluation("boom")
    def boom(ctx: FunctionContext) -> bool:
        raise AssertionError("must not be evaluated")

    @string("label")
    def label(ctx: FunctionContext, text: str) -> str | None:
        calls.append(text)
        return text or None

    return FunctionRegistry([mark, boom, label])


def test_failed_assignment_stops_evaluation_and_keeps_earlier_bindings():
    calls: list[str] = []
    registry = _recording_registry(calls)
    world = _map(_human("c1"))
    text = (
        '{CLASS #Human U ?c}, {VAR @a U F: label ("one")}, {CLASS #Object U ?ball},'
        ' {VAR @b U F: label ("two")} ! {E: boom ()}'
    )
    result = _eval(text, world, registry=registry)
    assert result == Evaluation(result=False, bindings={"?c": "Human/c1", "@a": "one"})
    assert calls == ["one"]
    assert world.aliases == {"?c": "Human/c1"} and world.variables == {"@a": "one"}


def test_f_function_returning_none_fails_the_assignment():
    registry = _recording_registry([])
    result = _eval('{VAR @a L F: label ("")} ! {TRUE}', _map(), registry=registry)
    assert result.result is False


def test_evaluations_run_left_to_right_and_stop_at_the_first_false():
    calls: list[str] = []
    registry = _recording_registry(calls)
    text = '! {E: mark ("a")}, {E: mark ("b", 0)}, {E: boom ()}'
    assert _eval(text, _map(), registry=registry).result is False
    assert calls == ["a", "b"]


def test_true_on_the_right_ends_evaluation_as_true():
    calls: list[str] = []
    registry = _recording_registry(calls)
    text = '! {E: mark ("a")}, {TRUE}, {E: boom ()}, {E: mark ("x", 0)}'
    assert _eval(text, _map(), registry=registry).result is True
    assert calls == ["a"]


def test_true_on_the_left_skips_later_assignments():
    world = _map(_human("c1"))
    result = _eval("{CLASS #Human U ?c}, {TRUE}, {CLASS #Object U ?o} ! {E: near (?c, 0)}", world)
    assert result == Evaluation(result=True, bindings={"?c": "Human/c1"})


def test_true_after_a_failed_assignment_is_not_reached():
    assert _eval("{CLASS #Object U ?o}, {TRUE} ! {TRUE}", _map()).result is False


def test_bare_true_and_empty_sides():
    world = _map()
    assert _eval("{TRUE}", world).result is True
    assert _eval("! {TRUE}", world).result is True
    assert _eval("!", world).result is True
    assert _eval("{CLASS #Human L ?c} !", world).result is False


def test_unbound_alias_makes_an_evaluation_false():
    world = _map(_human("c1", rho=0.1))
    assert _eval("! {E: near (?nobody, 1)}", world).result is False
    assert _eval("! {E: lost (?nobody)}", world).result is True
    assert _eval("{CLASS #Human L ?c} ! {E: lost (?c)}", world).result is False


def test_evaluation_never_parses(monkeypatch):
    condition = compile_condition(
        "{CLASS #Human U ?c ?THIS>&positionrho OP< 2} ! {E: near (?c, 3)}"
    )

    def refuse():
        raise AssertionError("parsed at evaluation time")

    monkeypatch.setattr(condition_parse, "_parser", refuse)
    assert condition.evaluate(_map(_human("c1")), now_ms=0).result is True


def test_evaluation_is_a_frozen_struct_that_encodes():
    result = _eval("{CLASS #Human L ?c} !", _map(_human("c1")))
    with pytest.raises(AttributeError):
        result.result = False  # type: ignore[misc]
    assert msgspec.json.decode(msgspec.json.encode(result), type=Evaluation) == result


# ----------------------------------------------------------------------------- casting


@pytest.mark.parametrize(
    ("criterion", "expected"),
    [
        ("?THIS>&positionrho OP< 1.5", True),
        ("?THIS>&positionrho OP> 1.5", False),
        ("?THIS>&positionrho OP= 1.25", True),
        ('?THIS>&positionrho OP< "2"', True),
        ('?THIS>&positionrho OP< "two"', False),
        ("?THIS>&creationtime OP= 7", True),
        ('?THIS>&id OP= "kid"', True),
        ('?THIS>&id OP< "l"', True),
        ("?THIS>&id OP= 7", False),
        ("?THIS>&positionrho OP< @limit", True),
        ("?THIS>&positionrho OP> @word", False),
        ("?THIS>&positionrho OP< @unset", False),
        ("?THIS>&positionrho OP= ?THIS>$rho", True),
        ("?THIS>&positionrho OP= ?THIS>$missing", False),
        ("?THIS>&positionrho OP< ?far>&positionrho", True),
        ("?THIS>&positionrho OP< ?ghost>&positionrho", False),
    ],
)
def test_comparison_casts_to_the_field_type(criterion, expected):
    world = _map(
        _human("kid", age_ms=7, rho=1.25, attributes={"rho": "1.25"}),
        _human("far", age_ms=9, rho=4.0),
    )
    world.aliases["?far"] = "Human/far"
    world.variables.update({"@limit": "1.5", "@word": "lots"})
    assert _eval(f"{{CLASS #Human L ?c {criterion}}} !", world).result is expected


def test_number_like_text_field_compares_numerically_with_a_number():
    world = _map(_human("7"))
    assert _eval("{CLASS #Human L ?c ?THIS>&id OP> 5} !", world).result is True
    assert _eval('{CLASS #Human L ?c ?THIS>&id OP> "50"} !', world).result is True  # as text


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        ('"true"', True),
        ('"1"', True),
        ("1", True),
        ('"s_true"', True),  # the thesis's spelling (tables 4.1 and 4.2)
        ("s_true", True),
        ('"false"', False),
        ('"s_false"', False),
        ('"maybe"', False),
    ],
)
def test_boolean_field_casts_texts_and_numbers(value, expected):
    world = WorldMap(obstacles=[Obstacle(id="w", creationtime=0, isfixed=True)])
    assert _eval(f"{{CLASS #Obstacle L ?w ?THIS>&isfixed OP= {value}}} !", world).result is expected


def test_number_argument_from_a_variable_is_cast_and_a_failed_cast_is_false():
    world = _map(_human("c1", rho=0.4))
    world.variables["@near"] = "0.5"
    world.variables["@bad"] = "close"
    assert _eval("{CLASS #Human L ?c} ! {E: near (?c, @near)}", world).result is True
    assert _eval("{CLASS #Human L ?c} ! {E: near (?c, @bad)}", world).result is False


def test_entity_argument_of_the_wrong_class_makes_the_call_false():
    world = WorldMap(robotstatus=RobotStatus(activities=[ActivityTracking(activityname="a")]))
    assert _eval("{CLASS #Activity L ?a} ! {E: near (?a, 5)}", world).result is False


# ---------------------------------------------------------------- bare-word literals


def test_a_bare_word_argument_is_a_string_literal():
    """Thesis 4.3: "The function FUNCT (a user-defined string associated to an implemented
    function in the parser of the grammar) ... with the possibly needed arguments VAL";
    the thesis writes literal arguments bare (``countOf (Human)``, ``konst (x)``)."""

    @string("konst")
    def konst(ctx: FunctionContext, value: str) -> str:
        return value

    @evaluation("countOf")
    def count_of(ctx: FunctionContext, cls: str, at_least: float = 1) -> bool:
        return len(getattr(ctx.world_map, cls.lower() + "s", [])) >= at_least

    registry = FunctionRegistry([konst, count_of, *default_registry().functions()])
    world = _map(_human("c1"))
    found = _eval('{VAR @v L F: konst (x)} ! {E: var_is (@v, "x")}', world, registry=registry)
    assert found.result
    assert _eval("! {E: countOf (Human)}", world, registry=registry).result
    assert not _eval("! {E: countOf (Object)}", world, registry=registry).result
    assert _eval("! {E: countOf (Human, 2)}", world, registry=registry).result is False
    assert _eval('! {E: equals (calm, "calm")}', world).result


def test_a_bare_word_where_a_number_is_expected_is_refused_at_load():
    """Thesis 4.3: a bare word is a string literal, so it is not a number."""
    with pytest.raises(RuleSyntaxError, match="expected a number here, got 'far'"):
        compile_condition("{CLASS #Human U ?c} ! {E: near (?c, far)}")
