"""Counts said in words."""

from oimi.pipeline.plurals import counted


def test_one_is_singular_and_other_counts_plural() -> None:
    assert counted(1, "script") == "1 script"
    assert [counted(n, "script") for n in (0, 2)] == ["0 scripts", "2 scripts"]
    assert counted(3, "activity") == "3 activities"
    assert counted(2, "day") == "2 days"
    assert counted(2, "contact episode") == "2 contact episodes"
