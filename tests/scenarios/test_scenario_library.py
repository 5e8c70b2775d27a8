"""The scenario library: every scenario passes its expectations, and the expectations pin
what each scenario is meant to show (a sibling run without the safety part fails them)."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import msgspec
import pytest
from oimi.pipeline.events import ActuatorCommands, Topic, WorldState
from oimi.pipeline.messages import AudioCommand
from oimi.pipeline.operator.generators import GreetingGenerator
from oimi.pipeline.operator.generators.greeting import BLIND_STEPS, REACH_M, STEP_MS
from oimi.pipeline.sink import MemorySink
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.schema import Between, MinDistance, RuleFired
from oimi.scenarios.session.runner import RunResult, Session, library_scenarios

LIBRARY = {path.stem: path for path in library_scenarios()}


def run(path: Path, *sinks: MemorySink) -> RunResult:
    session = Session(load_scenario(path))
    for sink in sinks:
        session.sink.add(sink)
    return session.run()


def failures(result: RunResult) -> list[str]:
    return [f"{v.name}: {v.detail}" for v in result.verdicts if not v.ok]


@pytest.mark.parametrize("path", list(LIBRARY.values()), ids=list(LIBRARY))
def test_library_scenario_passes_its_expectations(path: Path) -> None:
    result = run(path)
    assert result.verdicts, f"{path.name} has no expectations"
    assert failures(result) == []


@pytest.mark.parametrize("path", list(LIBRARY.values()), ids=list(LIBRARY))
def test_library_scenario_is_short_described_and_at_50_hz(path: Path) -> None:
    scenario = load_scenario(path).scenario
    assert scenario.description.strip()
    assert scenario.tick_hz == 50
    assert 14.0 <= scenario.duration_s <= 60.0


def test_library_covers_every_part_of_the_thesis() -> None:
    wanted = {
        "idle_alone",
        "idle_welcome",
        "test_dance",
        "blink",
        "greeting",
        "child_too_close",
        "child_leaves",
        "joystick_takeover",
        "joystick_without_lock",
        "operator_controls",
        "camera_fault",
        "three_activity_session",
        "caress_reward",
        "script_speed_clamped",
        "safety_script_without_rule",
        "safety_joystick_at_child",
        "safety_ring_fault",
        "safety_child_behind",
    }
    assert wanted <= set(LIBRARY)


def test_without_child_too_close_the_safety_supervisor_still_stops_short(tmp_path: Path) -> None:
    # The same crossing with the rule's alfa/omega messages taken out of the activity: the
    # behavioural layer is gone, the supervisor below it is not (contact at 0.55 m).
    library = LIBRARY["child_too_close"].parent
    script = (library / "activities" / "cross_the_room.txt").read_text()
    (tmp_path / "activities").mkdir()
    (tmp_path / "activities" / "cross_the_room.txt").write_text(
        "\n".join(line for line in script.splitlines() if "child_too_close" not in line)
    )
    (tmp_path / "no_rule.toml").write_text(LIBRARY["child_too_close"].read_text())
    result = run(tmp_path / "no_rule.toml")
    assert "child_too_close" not in result.summary.rules_fired
    assert result.summary.min_distance_m["child"] > 0.55 + 0.1 - 1e-3
    assert result.summary.contacts == 0
    assert result.summary.protective_stops >= 1
    failed = failures(result)
    assert any(f.startswith("child_too_close fires") for f in failed)


def test_a_script_removing_child_too_close_is_still_stopped_by_the_supervisor(
    tmp_path: Path,
) -> None:
    # The sibling without the alfa R: the behavioural rule acts first (and the supervisor
    # has nothing to stop); with it, only the supervisor is left, and it stops the robot.
    result = run(LIBRARY["safety_script_without_rule"])
    assert result.summary.protective_stops >= 1
    assert "child_too_close" not in result.summary.rules_fired
    library = LIBRARY["safety_script_without_rule"].parent
    (tmp_path / "activities").mkdir()
    for name in ("keep_watch.txt", "charge_ahead.txt"):
        text = (library / "activities" / name).read_text()
        if name == "charge_ahead.txt":
            text = "\n".join(line for line in text.splitlines() if "child_too_close" not in line)
        (tmp_path / "activities" / name).write_text(text)
    (tmp_path / "kept.toml").write_text(LIBRARY["safety_script_without_rule"].read_text())
    kept = run(tmp_path / "kept.toml")
    assert kept.summary.rules_fired["child_too_close"] > 0
    assert any(f.startswith("child_too_close was removed") for f in failures(kept))


def with_one_child(name: str) -> tuple[dict[int, WorldState], Callable[[int], float]]:
    """A library scenario's world states by tick, and the surface gap between the robot and
    its one child (radii 0.3 and 0.25 m) at a tick."""
    memory = MemorySink()
    run(LIBRARY[name], memory)
    states: dict[int, WorldState] = {s.tick: s for s in memory.on(Topic.WORLD_STATE)}  # type: ignore[misc]

    def gap(tick: int) -> float:
        robot, child = states[tick].robot, states[tick].humans[0]
        return math.hypot(child.x_m - robot.x_m, child.y_m - robot.y_m) - 0.55

    return states, gap


def test_the_joystick_at_a_child_is_slowed_brought_to_rest_and_drives_away_at_full_speed() -> None:
    states, gap = with_one_child("safety_joystick_at_child")
    slowed = [t for t in range(50, 350) if gap(t) < 0.5]
    assert slowed and max(states[t].robot.vx_mps for t in slowed) <= 0.2 + 1e-9
    # The stick still fully forward (6.0 s to 7.0 s): the robot creeps in ever more slowly
    # (its bound leaves room for the child to walk on; it rises a little with each camera
    # frame), no protective stop needed, and never within 0.2 m of them
    pushed = range(300, 350)
    assert max(states[t].robot.vx_mps for t in pushed) < 0.1
    assert all(gap(t) > 0.2 for t in pushed) and gap(349) < 0.25
    away = [states[t].robot.vx_mps for t in range(375, 475)]
    assert min(away) == pytest.approx(-0.5)
    assert gap(474) > gap(375) + 0.5


def test_a_child_the_camera_lost_behind_the_robot_is_watched_by_the_ring_not_its_old_row() -> None:
    states, gap = with_one_child("safety_child_behind")
    # Turned about (1 s to 3.1 s): the child is behind the robot, out of the camera's view;
    # driving away (5 s to 7 s) reaches full speed (their row once held it at 0.2 m/s)
    assert abs(abs(states[250].robot.theta_rad) - math.pi) < 0.1
    away = [math.hypot(states[t].robot.vx_mps, states[t].robot.vy_mps) for t in range(250, 350)]
    assert max(away) == pytest.approx(0.5, abs=2e-3)
    # Reversing at them (7 s to 13 s): the echo caps the closing speed in the slow zone
    slowed = [t for t in range(350, 650) if gap(t) < 0.5]
    assert slowed and max(states[t].robot.vx_mps for t in slowed) <= 0.2 + 1e-9
    assert min(gap(t) for t in range(350, 700)) > 0.1


def test_joystick_moves_the_robot_only_with_the_safety_lock() -> None:
    held = run(LIBRARY["joystick_takeover"]).summary
    free = run(LIBRARY["joystick_without_lock"]).summary
    assert held.max_speed_mps > 0.3
    assert held.rules_fired["joystick_note"] > 0
    assert free.max_speed_mps < 0.05


def test_operator_clear_empties_the_selection_at_the_end() -> None:
    result = run(LIBRARY["operator_controls"])
    assert result.summary.activities == {}
    assert result.summary.rejected_inputs == 0
    # ... though both activities ran: the summary keeps them, not the idle activity
    assert result.summary.ran == {"test_dance": "completed", "example_act": "completed"}


def test_each_caress_plays_the_chime_once_and_the_push_none() -> None:
    sink = MemorySink()
    run(LIBRARY["caress_reward"], sink)
    chimes = [
        event.time_ms
        for event in sink.on(Topic.ACTUATOR_COMMANDS)
        if isinstance(event, ActuatorCommands)
        for command in event.commands
        if isinstance(command, AudioCommand)
        and command.track_path == "reward_chime.wav"
        and not command.stop
    ]
    assert len(chimes) == 2
    assert 6000 < chimes[0] < 8000 and 14000 < chimes[1] < 16000


def test_rule_fired_counts_only_the_ticks_of_its_window() -> None:
    """touch_reward fires for each caress (6 s, 14 s) and not for the push (10 s)."""
    loaded = load_scenario(LIBRARY["caress_reward"])
    windows = [
        RuleFired(name="first caress", rule="touch_reward", after_s=6.0, by_s=9.0, at_least=10),
        RuleFired(name="push", rule="touch_reward", after_s=9.0, by_s=13.9, at_least=0, at_most=0),
        RuleFired(name="before", rule="touch_reward", by_s=5.9, at_least=1),
    ]
    scenario = msgspec.structs.replace(loaded.scenario, expect=windows)
    verdicts = Session(msgspec.structs.replace(loaded, scenario=scenario)).run().verdicts
    assert [(v.name, v.ok) for v in verdicts] == [
        ("first caress", True),
        ("push", True),
        ("before", False),
    ]
    assert verdicts[2].detail == "fired 0"


def test_min_distance_measures_centres_or_surfaces_as_asked() -> None:
    """The run's summary says 'closest (surface to surface)': an expectation can say so too."""
    loaded = load_scenario(LIBRARY["child_too_close"])
    both = [
        MinDistance(name="centres", human="child", at_least_m=0.5),
        MinDistance(name="surfaces", human="child", at_least_m=0.5, between=Between.SURFACES),
    ]
    scenario = msgspec.structs.replace(loaded.scenario, expect=both)
    result = Session(msgspec.structs.replace(loaded, scenario=scenario)).run()
    centres, surfaces = (float(v.detail.split()[1]) for v in result.verdicts)
    radii = loaded.scenario.robot.radius_m + next(
        h.radius_m for h in loaded.scenario.humans if h.id == "child"
    )
    assert surfaces == pytest.approx(centres - radii, abs=2e-3)
    assert surfaces == pytest.approx(result.summary.min_surface_distance_m["child"], abs=1e-3)
    assert [v.ok for v in result.verdicts] == [centres >= 0.5, surfaces >= 0.5]
    assert result.verdicts[1].name == "surfaces"
    assert result.verdicts[0].detail.endswith(" m (centre to centre)")
    assert result.verdicts[1].detail.endswith(" m (surface to surface)")


def test_greeting_auto_steps_reach_a_child_four_metres_away() -> None:
    g = GreetingGenerator()
    g.activate({})
    script = g.generate()
    steps = [
        block
        for block in script.goals[1].actions[0].blocks
        if getattr(block, "move", ()) and block.move[0].v_x > 0  # type: ignore[union-attr]
    ]
    step_m = 0.15 * STEP_MS / 1000
    assert len(steps) * step_m >= REACH_M - 1.0
    assert len(steps) == math.ceil((REACH_M - 1.0) / step_m) + BLIND_STEPS
    turned = sum(
        block.move[0].v_theta * block.move[0].duration / 1000  # type: ignore[union-attr]
        for block in script.goals[0].actions[0].blocks
        if getattr(block, "move", ())
    )
    assert turned >= 2 * math.pi
