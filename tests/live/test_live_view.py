"""The live view's frames: what the supervisor is doing, from its /safety episodes."""

from __future__ import annotations

import json

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

from oimi.live.protocol import encode_message
from oimi.live.view import LiveView


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
