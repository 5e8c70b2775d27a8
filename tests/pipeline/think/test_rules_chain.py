"""The daisy chain: alfa/omega actions A/R/D/B/C, the L/M/U lock, decisions as data."""

from __future__ import annotations

import pytest

from pipeline.messages import Human, MutexCmd, RuleAction, RuleMessage, WorldMap
from pipeline.think.chain import RuleChain
from pipeline.think.library import RULES
from pipeline.think.rules import Rule, RuleRegistry, diff


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
        ([msg(1, "x", "A"), msg(1, "x", "A", "U")], "already loaded"),
        ([msg(1, "x", "B", "U")], "is not held"),
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
    registry = RuleRegistry()

    @registry.register
    class Tag(Rule):
        rulecode = 7
        condition_text = "{CLASS #Human L ?kid ?THIS>&positionrho OP< 1.0} ! {TRUE}"

        def act(self, world_map, found, ctx) -> None:
            world_map.humans[0].attributes["tagged"] = "yes"

    chain = RuleChain(registry)
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


def test_registering_a_rule_with_a_bad_condition_fails_at_load_time() -> None:
    registry = RuleRegistry()

    class Bad(Rule):
        rulecode = 1
        condition_text = "! {E: no_such_function ()}"

    with pytest.raises(ValueError, match="no_such_function"):
        registry.register(Bad)


def test_diff_reports_leaves_only() -> None:
    changes = list(diff({"a": 1, "b": {"c": [1, 2]}}, {"a": 1, "b": {"c": [1, 3]}, "d": "x"}))
    assert [(c.path, c.old, c.new) for c in changes] == [("b.c[1]", "2", "3"), ("d", "null", '"x"')]
