"""The live view's frames: what the supervisor is doing, from its /safety episodes."""

from __future__ import annotations

import json
from pathlib import Path

from oimi.pipeline.events import (
    BodyState,
    MotionSource,
    SafetyIntervention,
    SafetyPhase,
    SafetyZone,
    Topic,
    WorldState,
)
from oimi.pipeline.operator.generator import Catalogue
from oimi.pipeline.operator.handler import GeneratorHandler
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.runner import Session

from oimi.live.protocol import encode_message
from oimi.live.view import LiveView

ROOT = Path(__file__).resolve().parents[2]


def episode(phase: SafetyPhase, zone: SafetyZone, tick: int) -> SafetyIntervention:
    return SafetyIntervention(
        tick=tick,
        time_ms=tick * 20,
        phase=phase,
        source=MotionSource.JOYSTICK,
        zone=zone,
        human="child",
        requested=(0.5, 0.0, 0.0),
        allowed=(0.2, 0.0, 0.0),
    )


def test_a_frame_holds_the_safety_episode_under_way_until_it_ends() -> None:
    view = LiveView(GeneratorHandler(Catalogue({})))
    robot = BodyState(id="robot", kind="robot", x_m=1.0, y_m=1.0, theta_rad=0.0)
    view.record(Topic.WORLD_STATE, 0, WorldState(tick=1, time_ms=20, robot=robot))
    assert view.frame(joystick_engaged=True).safety is None  # type: ignore[union-attr]
    for phase, zone, tick in [
        (SafetyPhase.START, SafetyZone.SLOW, 2),
        (SafetyPhase.CHANGE, SafetyZone.STOP, 3),
    ]:
        view.record(Topic.SAFETY, 0, episode(phase, zone, tick))
        frame = view.frame(joystick_engaged=True)
        assert frame is not None and frame.safety == episode(phase, zone, tick)
    sent = json.loads(encode_message(frame))
    assert sent["safety"]["zone"] == "stop" and sent["safety"]["human"] == "child"
    view.record(Topic.SAFETY, 0, episode(SafetyPhase.END, SafetyZone.STOP, 30))
    assert view.frame(joystick_engaged=True).safety is None  # type: ignore[union-attr]


def test_the_current_activity_shows_paused_while_a_rules_switch_runs_another_script() -> None:
    """child_leaves: the child walks away during play_together, child_left switches to
    wait_for_child; the console must say play_together waits, not that it runs."""
    loaded = load_scenario(ROOT / "scenarios" / "library" / "child_leaves.toml")
    session = Session(loaded)
    view = LiveView(session.pipeline.handler)
    session.sink.add(view)
    seen: list[tuple[str, str, str]] = []  # (current activity, block's activity, paused_by)
    for tick in range(session.scenario.ticks):
        session.step(tick)
        state = view.state()
        current = next((a.name for a in state.activities if a.state == "current"), "")
        shown = (current, state.block.activity, state.paused_by)
        if not seen or seen[-1] != shown:
            seen.append(shown)
    assert seen == [
        ("", "idle_activity", ""),
        ("play_together", "play_together", ""),
        ("play_together", "wait_for_child", "wait_for_child"),
        ("play_together", "play_together", ""),  # resumed once the child came back
        ("", "idle_activity", ""),
    ]
