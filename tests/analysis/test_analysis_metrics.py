from __future__ import annotations

from pathlib import Path

import polars as pl
import pytest
from oimi.analysis.load import load_session
from oimi.analysis.metrics import distances, session_metrics
from oimi.recorder.metadata import RecordingMetadata
from oimi.scenarios.simulation.humans import PACE


def _load(path: Path):
    return load_session(path, stream=True)


@pytest.fixture(scope="module")
def walk(walk_mcap: Path):
    return session_metrics(_load(walk_mcap))


@pytest.fixture(scope="module")
def too_close(too_close_mcap: Path):
    data = _load(too_close_mcap)
    return load_session(too_close_mcap), session_metrics(data)


@pytest.fixture(scope="module")
def joystick(joystick_mcap: Path):
    return session_metrics(_load(joystick_mcap))


def test_walking_child_spends_the_walk_time_in_each_zone(walk) -> None:
    row = walk["proximity"].row(0, named=True)
    # Radii 0.3 m (robot) and 0.25 m (child): the gap goes 3.45 m -> 0.25 m at 0.5 m/s times
    # the child's seeded pace: 2.25 m in the social zone (down to 1.2 m), 0.75 m in the
    # personal one (down to 0.45 m), then intimate (standing at 0.25 m to the end); never
    # touching. Whatever the pace, social time is 3 times personal time.
    walked = row["social_s"] + row["personal_s"]
    assert 3.0 / (0.5 * PACE[1]) - 0.1 <= walked <= 3.0 / (0.5 * PACE[0]) + 0.1
    assert row["social_s"] / row["personal_s"] == pytest.approx(3.0, rel=0.05)
    assert row["social_s"] + row["personal_s"] + row["intimate_s"] == pytest.approx(10.0)
    assert row["human"] == "child"
    assert row["contact_s"] == 0.0
    assert 0.15 <= row["min_surface_distance_m"] <= 0.25  # the idle robot turns and shifts a little
    assert walk["contacts"].height == 0
    summary = walk.summary.row(0, named=True)
    assert summary["duration_s"] == 10.0
    assert summary["activities_started"] == 0


def test_child_too_close_stops_the_robot_short_of_the_child(too_close) -> None:
    data, metrics = too_close
    rules = metrics["rules"].filter(pl.col("rule") == "child_too_close").row(0, named=True)
    assert rules["episodes"] >= 1
    first_ms = rules["first_ms"]
    closest = metrics["proximity"].row(0, named=True)["min_surface_distance_m"]
    assert 0.1 <= closest < 0.25
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
    assert operator["cmd"].to_list() == ["add", "get_ready", "start"]
    assert operator["ok"].to_list() == [True, True, True]
    assert operator.columns[-1] == "replied_ms"  # shown as "replied", a time (not "reply")
    assert operator["replied_ms"].to_list() == operator["time_ms"].to_list()  # the same tick


def test_joystick_takeovers_are_the_spans_with_the_lock_held(joystick) -> None:
    spans = joystick["joystick_takeovers"]
    assert spans[["started_ms", "ended_ms"]].rows() == [(3000, 6000), (8000, 10000)]
    assert spans["joystick_commands"].to_list() == [1, 1]
    summary = joystick.summary.row(0, named=True)
    assert summary["joystick_takeovers"] == 2
    assert summary["joystick_s"] == pytest.approx(5.0)
    assert summary["safety_interventions"] == 0  # no /safety topic in this recording
    commands = joystick["commands"]
    assert commands.filter(pl.col("source") == "joystick")["commands"].sum() == 2


def test_robot_speed_distance_and_no_rejections(joystick) -> None:
    robot = joystick["robot"].row(0, named=True)
    assert robot["max_speed_mps"] == pytest.approx(0.4, abs=1e-6)
    assert robot["distance_m"] > 1.0
    assert robot["clamps"] == 0
    assert joystick["rejections"].height == 0


def test_distances_are_surface_to_surface(walk_mcap: Path) -> None:
    frame = distances(_load(walk_mcap))
    first = frame.row(0, named=True)
    assert first["surface_distance_m"] == pytest.approx(4.0 - 0.3 - 0.25, abs=0.02)  # 1 tick in


def test_housekeeping_rules_are_folded_away_but_counted(too_close) -> None:
    _, metrics = too_close
    rules = metrics["rules"]
    assert rules.filter(pl.col("rule") == "kick_starter")["housekeeping"].to_list() == [True]
    assert "kick_starter" not in metrics["rule_episodes"]["rule"].to_list()
    assert metrics["rule_episodes"]["duration"].dt.total_milliseconds().min() > 0


def test_a_rule_firing_is_credited_to_the_activity_running_when_it_began() -> None:
    """Thesis 4.2: the rules propagate (step 8) after the Block Reader (steps 5-7); a rule
    that raises overridecmd names the target in currentactivity, but the switch is applied
    only at the next loop's step 5: the firing belongs to the activity that was running.
    An episode runs from the first evaluation that fired to the first that did not."""
    import msgspec
    from oimi.analysis.load import TIME, SessionData
    from oimi.analysis.metrics import rule_episodes
    from oimi.analysis.stream import StreamFolder
    from oimi.pipeline.events import RuleDecision, RuleDecisions

    items = pl.DataFrame(
        [
            {"tick": 0, "time_ms": 0, "kind": "idle", "activity": "idle_activity"},
            {"tick": 10, "time_ms": 200, "kind": "end", "activity": "idle_activity"},
            {"tick": 10, "time_ms": 200, "kind": "load", "activity": "game"},
            {"tick": 51, "time_ms": 1020, "kind": "switch", "activity": "game"},
            {"tick": 51, "time_ms": 1020, "kind": "load", "activity": "wait_for_child"},
        ]
    ).with_columns(pl.col("time_ms").cast(pl.Duration("ms")).alias(TIME))
    folder = StreamFolder(tick_ms=20)
    for tick, fired in ((10, {"close"}), (50, {"child_left"}), (51, {"close"}), (60, set())):
        decisions = tuple(
            RuleDecision(rule=r, rulecode=1, fired=r in fired) for r in ("close", "child_left")
        )
        message = RuleDecisions(tick=tick, time_ms=tick * 20, decisions=decisions)
        folder.add("/rules/decisions", msgspec.json.encode(message))
    data = SessionData(
        path="",
        session_id="",
        metadata=RecordingMetadata(),
        attachments={},
        tables={"/reader/progress/items": items},
        streamed=folder.result(),
    )
    credited = rule_episodes(data).select("started_ms", "ended_ms", "rule", "activity").rows()
    assert credited == [
        (200, 1000, "close", "game"),
        (1000, 1020, "child_left", "game"),
        (1020, 1200, "close", "wait_for_child"),
    ]


def test_the_run_summary_counts_the_episodes_oimi_analyse_lists(tmp_path: Path) -> None:
    """One definition: `oimi run`'s "x27 (3 episodes)" is `oimi analyse`'s episode table."""
    from oimi.analysis.metrics import rule_episodes
    from oimi.scenarios.loader import load_scenario
    from oimi.scenarios.session.recording import recorded
    from oimi.scenarios.session.runner import Session

    library = Path(__file__).resolve().parents[2] / "scenarios" / "library"
    session = Session(load_scenario(library / "caress_reward.toml"))
    with recorded(session, mcap=tmp_path / "c.mcap", rrd=None):
        summary = session.run().summary
    listed = rule_episodes(_load(tmp_path / "c.mcap"), housekeeping=True)
    counted = dict(listed.group_by("rule").len().sort("rule").rows())
    assert summary.rule_episodes == counted
    assert any(summary.rules_fired[r] > n for r, n in counted.items()), "some fired in runs"
