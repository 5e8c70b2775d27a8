"""The daisy chain: alfa/omega actions A/R/D/B/C, the L/M/U lock, decisions as data."""

from __future__ import annotations

import msgspec
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from oimi.pipeline.events import Level
from oimi.pipeline.messages import Human, MutexCmd, RuleAction, RuleMessage, WorldMap
from oimi.pipeline.registries import Registries
from oimi.pipeline.think.chain import RuleChain
from oimi.pipeline.think.mapparts import map_changes
from oimi.pipeline.think.rules import Effect, Rule, RuleRegistry, diff
from oimi.pipeline.think.stdlib import default_registry

RULES = Registries.build().rules


def msg(code: int, name: str, action: str, mutex: str = "M") -> RuleMessage:
    return RuleMessage(
        rulecode=code,
        id=name,
        intopic="",
        outtopic="",
        action=RuleAction[action],
        mutexcmd=MutexCmd[mutex],
    )


def test_a_adds_in_order_and_r_removes_keeping_the_rule_for_c() -> None:
    chain = RuleChain(RULES)
    assert chain.apply([msg(1, "close", "A"), msg(3, "touch", "A", "U")]) == []
    assert chain.names() == (("close", "touch"), (), ())
    chain.apply([msg(1, "close", "R", "L")])
    assert chain.names() == (("touch",), (), ("close",))
    removed = chain.removed["close"]
    chain.apply([msg(1, "close", "C", "U")])
    assert chain.names()[0] == ("touch", "close")
    assert chain.active[-1] is removed, "C recovers the very rule that R removed"


def test_d_holds_a_rule_until_b_brings_it_back() -> None:
    chain = RuleChain(RULES)
    chain.apply([msg(5, "battery", "D", "U")])
    assert chain.names() == ((), ("battery",), ())
    chain.apply([msg(5, "battery", "B", "U")])
    assert chain.names() == (("battery",), (), ())


def test_c_creates_a_rule_never_loaded_as_the_idle_activity_does() -> None:
    chain = RuleChain(RULES)
    chain.apply([msg(0, "kick_starter", "C", "U")])
    assert chain.names()[0] == ("kick_starter",)


@pytest.mark.parametrize(
    ("messages", "expected"),
    [
        ([msg(99, "ghost", "A", "U")], "unknown rule code 99"),
        ([msg(1, "x", "A"), msg(1, "x", "A", "U")], "is loaded already (active)"),
        ([msg(1, "x", "B", "U")], "is absent, not held"),
        ([msg(1, "never", "R", "U")], "is not loaded"),
    ],
)
def test_messages_that_cannot_apply_are_reported_not_raised(messages, expected) -> None:
    problems = RuleChain(RULES).apply(messages)
    assert len(problems) == 1 and expected in problems[0].message


def test_l_locks_propagation_until_u() -> None:
    chain = RuleChain(RULES)
    chain.apply([msg(0, "kick_starter", "C", "L")])
    world = WorldMap()
    assert chain.locked and chain.propagate(world, now_ms=0) == []
    chain.apply([msg(1, "close", "A", "U")])
    assert not chain.locked
    assert [d.rule for d in chain.propagate(world, now_ms=0)] == ["kick_starter", "close"]


def test_a_decision_names_bindings_and_the_map_fields_the_body_changed() -> None:
    class Tag(Rule):
        rulecode = 7
        condition_text = "{CLASS #Human L ?kid ?THIS>&positionrho OP< 1.0} ! {TRUE}"

        def act(self, world_map, found, ctx) -> None:
            world_map.humans[0].attributes["tagged"] = "yes"

    chain = RuleChain(RuleRegistry([Tag], functions=default_registry()))
    chain.apply([msg(7, "tag", "A", "U")])
    world = WorldMap(humans=[Human(id="c1", creationtime=0, positionrho=0.5)])
    (decision,) = chain.propagate(world, now_ms=40)
    assert decision.fired and decision.bindings == {"?kid": "Human/c1"}
    assert [(c.path, c.old, c.new) for c in decision.changes] == [
        ("humans[0].attributes.tagged", "null", '"yes"')
    ]
    world.humans[0].positionrho = 2.0
    (decision,) = chain.propagate(world, now_ms=60)
    assert not decision.fired and decision.changes == ()


@pytest.mark.parametrize("shortcuts", [True, False])
def test_an_alias_a_condition_binds_is_not_the_next_bodys_change(shortcuts: bool) -> None:
    """A fired rule encodes the map's parts; a condition then binds a scope-U alias (not
    a body's doing, and no change of the body after it). The body after that changes one
    variable: that is all it reports (the alias once came with it, from a stale encoding)."""

    class Look(Rule):
        rulecode = 20
        condition_text = "! {TRUE}"

    class Bind(Rule):
        rulecode = 21
        condition_text = "{CLASS #Human U ?pal} ! {E: far (?pal, 3.0)}"

    class Note(Rule):
        rulecode = 22
        condition_text = "! {TRUE}"

        def act(self, world_map, found, ctx) -> Effect:
            world_map.variables["@noted"] = "yes"
            return Effect.CHANGED

    registry = RuleRegistry([Look, Bind, Note], functions=default_registry())
    chain = RuleChain(registry, shortcuts=shortcuts)
    chain.apply([msg(20, "look", "A", "U"), msg(21, "bind", "A", "U"), msg(22, "note", "A", "U")])
    world = WorldMap(humans=[Human(id="c1", creationtime=0, positionrho=1.0)])
    look, bind, note = chain.propagate(world, now_ms=0)
    assert look.fired and not bind.fired and world.aliases == {"?pal": "Human/c1"}
    assert [(c.path, c.new) for c in note.changes] == [("variables.@noted", '"yes"')]


def test_registering_a_rule_with_a_bad_condition_fails_at_load_time() -> None:
    class Bad(Rule):
        rulecode = 1
        condition_text = "! {E: no_such_function ()}"

    with pytest.raises(ValueError, match="no_such_function"):
        RuleRegistry([Bad], functions=default_registry())


def test_two_rules_with_one_code_are_refused_naming_both() -> None:
    class First(Rule):
        rulecode = 1000

    class Second(Rule):
        rulecode = 1000

    with pytest.raises(ValueError, match="1000 of Second is taken by First"):
        RuleRegistry([First, Second], functions=default_registry())


def test_diff_reports_leaves_only() -> None:
    changes = list(diff({"a": 1, "b": {"c": [1, 2]}}, {"a": 1, "b": {"c": [1, 3]}, "d": "x"}))
    assert [(c.path, c.old, c.new) for c in changes] == [("b.c[1]", "2", "3"), ("d", "null", '"x"')]


def test_diff_reads_values_as_the_recorded_json_does() -> None:
    """A non-finite number is ``null`` in the map's JSON: NaN to NaN (or to infinity) is
    no change; a number becoming NaN is one. A long value is cut, after comparing it whole."""
    nan, inf = float("nan"), float("inf")
    old = {"x": nan, "y": inf, "z": 1.5, "long": ["a" * 200, 1]}
    new = {"x": nan, "y": -inf, "z": nan, "long": ["a" * 200, 2]}
    changes = [(c.path, c.old, c.new) for c in diff(old, new)]
    assert changes[0] == ("z", "1.5", "null")
    assert [c[0] for c in changes] == ["z", "long[1]"]
    cut = list(diff({"v": "a" * 200 + "b"}, {"v": "a" * 200 + "c"}))
    assert len(cut) == 1 and cut[0].old == cut[0].new and cut[0].old.endswith("…")


LEAVES = st.sampled_from([0.0, -0.0, 1, 1.0, True, None, "a", float("nan"), float("inf")])
TREES = st.recursive(
    LEAVES,
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.sampled_from("ab"), inner),
    max_leaves=8,
)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(TREES | st.lists(TREES, max_size=4), TREES | st.lists(TREES, max_size=4))
def test_a_body_s_changes_are_the_diff_of_the_whole_parts(old, new) -> None:
    """A listed part is compared item by item (only items whose encodings differ are
    decoded): the changes are those of the whole parts' diff, in its order."""
    before, after = {"humans": msgspec.msgpack.encode(old)}, {"humans": msgspec.msgpack.encode(new)}
    whole = msgspec.msgpack.decode
    expected = (
        ()
        if before == after
        else tuple(diff(whole(before["humans"]), whole(after["humans"]), "humans"))
    )
    assert map_changes(before, after) == expected


# ------------------------------------------------------------ one state per rule (issue 16)

STATES = ("absent", "active", "held", "removed")


def state_of(chain: RuleChain, name: str) -> str:
    active, held, removed = chain.names()
    found = [
        s for s, names in zip(STATES[1:], (active, held, removed), strict=True) if name in names
    ]
    assert len(found) <= 1, f"{name!r} is {found} at once"
    return found[0] if found else "absent"


def test_c_on_a_held_rule_is_refused_and_b_then_makes_one_instance() -> None:
    """Thesis 4.4: "C -> recover a removed rule and put it among the active ones"."""
    chain = RuleChain(RULES)
    chain.apply([msg(1, "tr", "D", "U")])
    (problem,) = chain.apply([msg(1, "tr", "C", "U")])
    assert problem.message == "C: rule 'tr' is held, not removed" and problem.ref == "tr"
    assert problem.level == Level.WARNING
    assert chain.names() == ((), ("tr",), ())
    assert chain.apply([msg(1, "tr", "B", "U")]) == []
    assert len(chain.propagate(WorldMap(), now_ms=0)) == 1, "one instance fires once per pass"


def test_c_on_an_active_rule_is_refused_with_a_reason() -> None:
    """Thesis 4.4: "C -> recover a removed rule and put it among the active ones"."""
    chain = RuleChain(RULES)
    chain.apply([msg(1, "tr", "A", "U")])
    (problem,) = chain.apply([msg(1, "tr", "C", "U")])
    assert problem.message == "C: rule 'tr' is already active, not removed"
    assert problem.level == Level.INFO, "harmless: the rule is where C would put it"
    assert chain.names() == (("tr",), (), ())


def test_b_on_an_active_rule_and_r_on_a_removed_rule_are_refused() -> None:
    """Thesis 4.4: "B -> bring back to the active ones the delayed rule"; "R -> remove the rule"."""
    chain = RuleChain(RULES)
    chain.apply([msg(1, "tr", "A", "U")])
    (problem,) = chain.apply([msg(1, "tr", "B", "U")])
    assert "B: rule 'tr' is active, not held" in problem.message
    chain.apply([msg(1, "tr", "R", "U")])
    (problem,) = chain.apply([msg(1, "tr", "R", "U")])
    assert problem.message == "R: rule 'tr' is already removed" and problem.level == Level.INFO
    assert chain.names() == ((), (), ("tr",))
    (problem,) = chain.apply([msg(1, "never", "R", "U")])
    assert problem.message == "R: rule 'never' is not loaded" and problem.level == Level.WARNING


def test_r_on_a_held_rule_removes_it_and_c_recovers_it_as_active() -> None:
    """Thesis 4.4: "R -> remove the rule"; "C -> recover a removed rule and put it among the
    active ones"."""
    chain = RuleChain(RULES)
    chain.apply([msg(5, "battery", "D", "U")])
    chain.apply([msg(5, "battery", "R", "U")])
    assert chain.names() == ((), (), ("battery",))
    chain.apply([msg(5, "battery", "C", "U")])
    assert chain.names() == (("battery",), (), ())


def model_step(state: str, action: str) -> tuple[str, bool]:
    """The tiny model: a rule's next state and whether the message was accepted.

    A/D load a rule that is absent or removed (a fresh instance); R removes an active or
    held one; B brings a held one back; C recovers a removed one (and, as the thesis's
    idle activity needs, creates one never loaded)."""
    table = {
        "A": {"absent": "active", "removed": "active"},
        "D": {"absent": "held", "removed": "held"},
        "R": {"active": "removed", "held": "removed"},
        "B": {"held": "active"},
        "C": {"removed": "active", "absent": "active"},
    }
    after = table[action].get(state)
    return (after, True) if after else (state, False)


NAMES = ("r1", "r2")


@settings(max_examples=150, deadline=None, derandomize=True)
@given(
    st.lists(
        st.tuples(st.sampled_from(NAMES), st.sampled_from("ARDBC"), st.sampled_from("LMU")),
        max_size=25,
    )
)
def test_the_chain_follows_the_state_model_and_never_makes_two_instances(sequence) -> None:
    """Thesis 4.4: "A -> activate and add the rule to the active ones / R -> remove the rule /
    D -> activate and delay rule for a future usage / B -> bring back to the active ones the
    delayed rule / C -> recover a removed rule and put it among the active ones"."""
    chain = RuleChain(RULES)
    model = dict.fromkeys(NAMES, "absent")
    order: list[str] = []
    for name, action, mutex in sequence:
        expected, accepted = model_step(model[name], action)
        problems = chain.apply([msg(1, name, action, mutex)])
        assert (problems == []) == accepted, (name, action, model[name], problems)
        if accepted and expected == "active":
            order.append(name)
        if model[name] == "active" and expected != "active":
            order.remove(name)
        model[name] = expected
        for each in NAMES:
            assert state_of(chain, each) == model[each]
        assert [rule.name for rule in chain.active] == order, (
            "the chain stays ordered by activation"
        )
        assert len({id(rule) for rule in chain.active}) == len(chain.active)
    chain.unlock()
    fired = [d.rule for d in chain.propagate(WorldMap(), now_ms=0)]
    assert fired == order, "each active rule decides exactly once per pass"
