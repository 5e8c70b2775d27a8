"""What the safety supervisor reads: the map as the sensors alone made it. A rule, script
or function may change the shared map as it likes; it cannot hide a person from the
supervisor, move one away or make an old reading look fresh."""

from __future__ import annotations

from collections.abc import Callable

import pytest
from loop_pipeline import camera, frame, pipeline, pose
from oimi.pipeline.events import JoystickInput, Level, Topic
from oimi.pipeline.loop import Pipeline
from oimi.pipeline.messages import Camera, WorldMap
from oimi.pipeline.sink import MemorySink

Tamper = Callable[[WorldMap, int], None]


def erase(world: WorldMap, now_ms: int) -> None:
    world.humans.clear()
    world.obstacles.clear()


def move_away(world: WorldMap, now_ms: int) -> None:
    for human in world.humans:
        human.positionrho, human.positiontheta = 50.0, 3.14
        human.positionchangetime = now_ms


def freshen(world: WorldMap, now_ms: int) -> None:
    for human in world.humans:
        human.positionchangetime = now_ms


def see_again(world: WorldMap, now_ms: int) -> None:
    world.cameras[:] = [Camera(id="front", isonline=True)]


def drive(p: Pipeline, tamper: Tamper | None, rho: float, seeing: bool) -> list[tuple]:
    """The pad pushes the robot at a child ``rho`` m ahead for 1.2 s (a reading at the start
    only: it goes stale), the camera reported on or off (``seeing``: off, nothing senses
    the room; on, it frames every 100 ms); ``tamper`` changes the shared map after every
    tick, as a rule's body at the end of the chain would. The body's commands, tick by
    tick."""
    outputs = []
    for tick in range(60):
        pad = JoystickInput(tick=tick, time_ms=tick * 20, left_y=1.0, buttons=("LB",))
        updates = [camera(1, online=seeing), pose(2, rho, 0)] if tick == 0 else []
        if seeing and tick % 5 == 0:
            updates.append(frame(3 + tick, tick * 20))
        out = p.tick(tick=tick, updates=updates, joystick=pad)
        outputs.append((out.v_x, out.v_y, out.brake))
        if tamper is not None:
            tamper(p.map, tick * 20)
    return outputs


@pytest.mark.parametrize(
    ("tamper", "rho", "seeing"),
    [(erase, 0.75, True), (move_away, 0.75, True), (freshen, 0.75, True), (see_again, 3.0, False)],
)
def test_a_rule_changing_the_map_changes_nothing_the_supervisor_allows(tamper, rho, seeing) -> None:
    untouched, tampered = MemorySink(), MemorySink()
    expected = drive(pipeline(untouched), None, rho, seeing)
    assert any(brake for _, _, brake in expected), "the supervisor limits this drive"
    assert any(v_x > 0 for v_x, _, _ in expected) is seeing, "it moves while it senses"
    assert drive(pipeline(tampered), tamper, rho, seeing) == expected
    assert tampered.on(Topic.SAFETY) == untouched.on(Topic.SAFETY)


def test_a_perceived_map_the_supervisor_cannot_read_stops_the_robot_and_is_said_once() -> None:
    """The fail-safe under it all: a value of the wrong type where the supervisor reads
    (no rule reaches that map; a fault in oimi could) stops the robot until it reads again."""
    sink = MemorySink()
    p = pipeline(sink)
    p.tick(tick=0, updates=[camera(1), frame(2, 0), pose(3, 3.0, 0)])
    push = JoystickInput(tick=1, time_ms=20, left_y=1.0, buttons=("LB",))
    assert p.tick(tick=1, joystick=push).v_x > 0, "the pad drives it"
    p.producer.perceived.humans[0].positionchangetime = "later"  # type: ignore[assignment]
    for tick in (2, 3, 4):
        held = JoystickInput(tick=tick, time_ms=tick * 20, left_y=1.0, buttons=("LB",))
        out = p.tick(tick=tick, joystick=held)
        assert (out.v_x, out.v_y, out.brake) == (0.0, 0.0, True)
    said = [e for m in sink.on(Topic.LOG) for e in m.entries if e.source == "safety"]
    assert [(e.level, e.message) for e in said] == [
        (
            Level.ERROR,
            "cannot read the map (humans[0].positionchangetime: Expected `int`, got `str`):"
            " the robot is stopped",
        )
    ]
    p.producer.perceived.humans[0].positionchangetime = 40
    held = JoystickInput(tick=5, time_ms=100, left_y=1.0, buttons=("LB",))
    assert p.tick(tick=5, joystick=held).v_x > 0, "readable again: it moves"
