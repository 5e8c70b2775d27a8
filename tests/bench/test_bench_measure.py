"""Peak memory is each child's own (VmHWM), so a memory case can tell two runs apart."""

from __future__ import annotations

from oimi.bench.measure import bench_session, beside, in_child, interleaved, peak_memory_mb

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


def test_the_crowded_bench_session_adds_children_who_move() -> None:
    few, many = bench_session(50), bench_session(50, extra_children=9)
    assert len(many.scenario.humans) == len(few.scenario.humans) + 9 == 12
    assert len({h.id for h in many.scenario.humans}) == 12
    start = {h.id: (h.x_m, h.y_m) for h in many.scenario.humans}
    many.run()
    moved = [who for who, x, y in many.world.human_positions() if (x, y) != start[who]]
    assert len(moved) >= 9, "the added children wander like the scenario's own"


def test_interleaved_works_run_in_turn_and_keep_their_results() -> None:
    order: list[str] = []
    first, second = interleaved(3, lambda: order.append("a") or 1, lambda: order.append("b") or 2)
    assert order == ["a", "b", "a", "b", "a", "b"]
    assert [result for _, result in first] == [1, 1, 1]
    assert [result for _, result in second] == [2, 2, 2]
