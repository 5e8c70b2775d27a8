"""Texts cut for people: at most the length asked for, the cut shown."""

from __future__ import annotations

from oimi.pipeline.texts import clipped


def test_a_text_within_the_length_is_kept_and_a_longer_one_cut_to_it_with_an_ellipsis() -> None:
    assert clipped("hello", 5) == "hello"
    assert clipped("hello!", 5) == "hell…"
    assert len(clipped("x" * 500, 40)) == 40
