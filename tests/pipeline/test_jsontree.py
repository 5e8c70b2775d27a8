"""One JSON-tree diff: what the rule decisions and the replay comparison both read."""

from __future__ import annotations

from oimi.pipeline.jsontree import ABSENT, differences
from oimi.pipeline.think.rules import diff
from oimi.replay.compare import first_difference

OLD = {"a": 1, "b": {"c": [1, 2]}, "gone": "x"}
NEW = {"a": 1, "b": {"c": [1, 3, 4]}, "new": True}


def test_every_differing_leaf_in_key_order_with_absent_sides() -> None:
    assert list(differences(OLD, NEW, "$")) == [
        ("$.b.c[1]", 2, 3),
        ("$.b.c[2]", ABSENT, 4),
        ("$.gone", "x", ABSENT),
        ("$.new", ABSENT, True),
    ]


def test_whole_lists_make_a_length_change_one_difference() -> None:
    assert next(differences(OLD, NEW, whole_lists=True)) == ("b.c", [1, 2], [1, 3, 4])


def test_rule_changes_and_replay_comparison_read_the_same_walk() -> None:
    assert [(c.path, c.old, c.new) for c in diff(OLD, NEW)] == [
        ("b.c", "[1,2]", "[1,3,4]"),
        ("gone", '"x"', "null"),
        ("new", "null", "true"),
    ]
    assert first_difference(OLD, NEW) == ("$.b.c[1]", 2, 3)
    assert first_difference(OLD, dict(OLD)) is None


def test_exact_walks_tell_equal_numbers_of_different_types_apart() -> None:
    assert list(differences({"a": [1]}, {"a": [1.0]})) == []
    assert list(differences({"a": [1]}, {"a": [1.0]}, exact=True)) == [("a[0]", 1, 1.0)]
