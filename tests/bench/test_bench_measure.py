"""Peak memory is each child's own (VmHWM), so a memory case can tell two runs apart."""

from __future__ import annotations

from oimi.bench.measure import beside, in_child, peak_memory_mb

MB = 1024 * 1024


def hold(megabytes: int) -> float:
    """In a child: touch ``megabytes`` MiB, then report the child's peak memory."""
    ballast = b"\x01" * (megabytes * MB)
    assert len(ballast) == megabytes * MB
    return peak_memory_mb()


def test_a_childs_peak_memory_is_its_own_not_its_parents() -> None:
    ballast = b"\x01" * (200 * MB)  # raises this process's peak well above a fresh child's
    parent = peak_memory_mb()
    idle = in_child(hold, 0)
    busy = in_child(hold, 100)
    assert len(ballast) == 200 * MB
    assert parent > 200
    assert idle < parent - 150, "a spawned child reported its parent's high-water mark"
    assert busy - idle > 90, "the child's own allocation does not show in its peak"


def test_a_case_beside_another_figure_has_their_ratio() -> None:
    case = beside("run", 50.0, "ticks/s", "reference loop", 200.0)
    assert case.ratio == 0.25
    assert beside("run", 50.0, "ticks/s", "reference loop", 0.0).ratio is None
