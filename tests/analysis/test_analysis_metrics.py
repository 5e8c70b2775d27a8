from __future__ import annotations

from pathlib import Path

import polars as pl
import pytest

from analysis.load import load_session
from analysis.metrics import distances, session_metrics


@pytest.fixture(scope="module")
def walk(walk_mcap: Path):
    return session_metrics(load_session(walk_mcap))


@pytest.fixture(scope="module")
def too_close(too_close_mcap: Path):
    data = load_session(too_close_mcap)
    return data, session_metrics(data)


@pytest.fixture(scope="module")
def joystick(joystick_mcap: Path):
    return session_metrics(load_session(joystick_mcap))


def test_walking_child_spends_the_walk_time_in_each_zone(walk) -> None:
    row = walk["proximity"].row(0, named=True)
    # 4.0 m -> 0.8 m at 0.5 m/s: 3.6 -> 1.2 m is 4.8 s (social); 1.2 -> 0.8 m is 0.8 s, then
    # standing from 6.4 s to 10 s (personal); never intimate.
    assert row["human"] == "child"
    assert row["social_s"] == pytest.approx(4.8, abs=0.2)
    assert row["personal_s"] == pytest.approx(4.4, abs=0.2)
    assert row["intimate_s"] == 0.0
    assert row["min_distance_m"] == pytest.approx(0.8, abs=0.1)
    summary = walk.summary.row(0, named=True)
    assert summary["duration_s"] == 10.0
    assert summary["activities_started"] == 0


def test_child_too_close_stops_the_robot_short_of_the_child(too_close) -> None:
    data, metrics = too_close
    rules = metrics["rules"].filter(pl.col("rule") == "child_too_close").row(0, named=True)
    assert rules["fired"] >= 1
    first_ms = rules["first_ms"]
    closest = metrics["proximity"].row(0, named=True)["min_distance_m"]
    assert 0.65 <= closest < 0.8
    stop = data["/actuator/commands"].filter(
        (pl.col("channel") == "move") & pl.col("stop") & (pl.col("time_ms") >= first_ms)
    )
    assert stop["time_ms"].min() <= first_ms + 40
    world = data["/world/state"]
    speed_after = world.filter(pl.col("time_ms").is_between(first_ms + 500, first_ms + 1000))
    assert (speed_after["robot_vx_mps"].abs() < 1e-6).all()
    by_activity = metrics["rules_by_activity"].filter(pl.col("rule") == "child_too_close")
    assert by_activity["activity"].to_list() == ["cross_the_room"]


def test_activity_timeline_and_goals_follow_the_reader(too_close) -> None:
    _, metrics = too_close
    work = metrics["activities"].filter(~pl.col("idle")).row(0, named=True)
    assert work["activity"] == "cross_the_room"
    assert work["outcome"] == "completed"
    assert work["selected_ms"] == 0
    assert work["started_ms"] == 20
    assert work["ended_ms"] > 12_000
    assert metrics["goals"]["name"].to_list() == ["cross", "turn_round"]
    assert set(metrics["goals"]["outcome"]) == {"reached"}


def test_operator_commands_carry_their_replies(too_close) -> None:
    _, metrics = too_close
    operator = metrics["operator"]
    assert operator["verb"].to_list() == ["add", "get_ready", "start"]
    assert operator["ok"].to_list() == [True, True, True]


def test_joystick_interventions_are_the_spans_with_the_lock_held(joystick) -> None:
    spans = joystick["interventions"]
    assert spans[["started_ms", "ended_ms"]].rows() == [(3000, 6000), (8000, 10000)]
    assert spans["joystick_commands"].to_list() == [1, 1]
    summary = joystick.summary.row(0, named=True)
    assert summary["interventions"] == 2
    assert summary["intervention_s"] == pytest.approx(5.0)
    commands = joystick["commands"]
    assert commands.filter(pl.col("source") == "joystick")["commands"].sum() == 2


def test_robot_speed_distance_and_no_rejections(joystick) -> None:
    robot = joystick["robot"].row(0, named=True)
    assert robot["max_speed_mps"] == pytest.approx(0.4, abs=1e-6)
    assert robot["distance_m"] > 1.0
    assert robot["clamps"] == 0
    assert joystick["rejections"].height == 0


def test_distances_are_centre_to_centre(walk_mcap: Path) -> None:
    frame = distances(load_session(walk_mcap))
    first = frame.row(0, named=True)
    assert first["distance_m"] == pytest.approx(4.0, abs=0.01)


def test_a_rule_firing_is_credited_to_the_activity_running_when_it_fired() -> None:
    """Thesis 4.2: the rules propagate (step 8) after the Block Reader (steps 5-7); a rule
    that raises overridecmd names the target in currentactivity, but the switch is applied
    only at the next loop's step 5: the firing belongs to the activity that was running."""
    from analysis.load import TIME, SessionData
    from analysis.metrics import fired_rules

    def frame(rows: list[dict]) -> pl.DataFrame:
        return pl.DataFrame(rows).with_columns(
            pl.col("time_ms").cast(pl.Duration("ms")).alias(TIME)
        )

    progress = frame(
        [
            {"tick": 0, "time_ms": 0, "activity": "idle_activity"},
            {"tick": 10, "time_ms": 200, "activity": "game"},
            {"tick": 50, "time_ms": 1000, "activity": "wait_for_child"},  # set by the rule
            {"tick": 51, "time_ms": 1020, "activity": "wait_for_child"},
        ]
    )
    items = frame(
        [
            {"tick": 0, "time_ms": 0, "kind": "idle", "activity": "idle_activity"},
            {"tick": 10, "time_ms": 200, "kind": "end", "activity": "idle_activity"},
            {"tick": 10, "time_ms": 200, "kind": "load", "activity": "game"},
            {"tick": 51, "time_ms": 1020, "kind": "switch", "activity": "game"},
            {"tick": 51, "time_ms": 1020, "kind": "load", "activity": "wait_for_child"},
        ]
    )
    decisions = frame(
        [
            {"tick": 10, "time_ms": 200, "rule": "close", "fired": True},
            {"tick": 50, "time_ms": 1000, "rule": "child_left", "fired": True},
            {"tick": 51, "time_ms": 1020, "rule": "close", "fired": True},
        ]
    )
    data = SessionData(
        path="",
        session_id="",
        metadata={},
        attachments={},
        tables={
            "/reader/progress": progress,
            "/reader/progress/items": items,
            "/rules/decisions": decisions,
        },
    )
    credited = fired_rules(data).select("tick", "rule", "activity").rows()
    assert credited == [
        (10, "close", "game"),
        (50, "child_left", "game"),
        (51, "close", "wait_for_child"),
    ]
