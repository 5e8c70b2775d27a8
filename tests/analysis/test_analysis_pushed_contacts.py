"""A robot pushed into a person by another is not said to have initiated the contact."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from oimi.analysis.load import load_session
from oimi.analysis.metrics import session_metrics
from oimi.pipeline.events import ActuatorCommands, BodyState, WorldState
from oimi.pipeline.messages import MoveCommand, Source
from oimi.pipeline.proximity import Initiator, ProximityTracker
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.runner import Session

SCENARIOS = Path(__file__).resolve().parent / "scenarios"


def _first_contact(
    *,
    drive: tuple[float, float] | None = None,
    stop_after: bool = False,
    theta_rad: float = 0.0,
    pusher_vx_mps: float = -0.5,
    pusher_touching: bool = True,
) -> Initiator:
    """Who initiated the contact of a robot moving at 0.3 m/s (-x) into a standing child
    ("still", 0.1 m away at first), while another child ("pusher") is at its other side,
    touching it or not; ``drive`` is the robot's last move command (body frame)."""
    tracker = ProximityTracker(tick_ms=20)
    if drive is not None:
        move = MoveCommand(source=Source.SCRIPT, v_x=drive[0], v_y=drive[1])
        tracker.command(ActuatorCommands(tick=0, time_ms=0, commands=(move,)))
    if stop_after:
        stop = MoveCommand(source=Source.SCRIPT, stop=True)
        tracker.command(ActuatorCommands(tick=0, time_ms=0, commands=(stop,)))
    for tick, x_m in enumerate((0.0, -0.1)):
        robot = BodyState(
            id="robot",
            kind="robot",
            x_m=x_m,
            y_m=0.0,
            theta_rad=theta_rad,
            vx_mps=-0.3,
            radius_m=0.3,
        )
        still = BodyState(id="still", kind="child", x_m=-0.6, y_m=0.0, radius_m=0.2)
        pusher = BodyState(
            id="pusher", kind="child", x_m=x_m + 0.5, y_m=0.0, vx_mps=pusher_vx_mps, radius_m=0.2
        )
        touching = ("pusher",) if pusher_touching else ()
        tracker.update(
            WorldState(
                tick=tick, time_ms=tick * 20, robot=robot, humans=(still, pusher), contacts=touching
            )
        )
    (episode,) = [e for e in tracker.finish() if e.human == "still"]
    return episode.initiator


def test_a_robot_pushed_by_a_child_pressing_into_it_did_not_initiate() -> None:
    assert _first_contact() is Initiator.PUSHED  # no move command: it stands
    assert _first_contact(drive=(0.2, 0.0)) is Initiator.PUSHED  # its drive: away from them
    assert _first_contact(drive=(-0.2, 0.0), stop_after=True) is Initiator.PUSHED


def test_a_robot_that_drove_towards_the_person_initiated_even_when_pushed() -> None:
    assert _first_contact(drive=(-0.2, 0.0)) is Initiator.ROBOT
    # its body faces -x: a forward command drives it towards the child standing there
    assert _first_contact(drive=(0.2, 0.0), theta_rad=math.pi) is Initiator.ROBOT
    assert _first_contact(drive=(0.0, 0.2), theta_rad=math.pi / 2) is Initiator.ROBOT


def test_without_someone_pressing_into_it_a_moving_robot_initiated() -> None:
    """A robot coasting after a stop, or merely touched, is not pushed."""
    assert _first_contact(pusher_touching=False) is Initiator.ROBOT
    assert _first_contact(pusher_vx_mps=0.5) is Initiator.ROBOT  # the other child steps away


def _rolled_into(*, pushed_ms: int, drive: tuple[float, float] | None = None) -> Initiator:
    """Who initiated the contact of a robot rolling at 0.3 m/s (-x) into a standing child,
    ``pushed_ms`` after another child pressed into it and stepped back; ``drive``: a move
    command the robot had since (body frame)."""
    tracker = ProximityTracker(tick_ms=20)
    still = BodyState(id="still", kind="child", x_m=-0.65, y_m=0.0, radius_m=0.2)
    for time_ms in range(0, pushed_ms + 20, 20):
        x_m = -0.2 if time_ms == pushed_ms else -0.1  # 5 cm from still, then touching
        robot = BodyState(id="robot", kind="robot", x_m=x_m, y_m=0.0, vx_mps=-0.3, radius_m=0.3)
        pressing = time_ms == 0
        pusher = BodyState(
            id="pusher",
            kind="child",
            x_m=0.4 if pressing else 1.0,
            y_m=0.0,
            vx_mps=-0.5 if pressing else 0.5,
            radius_m=0.2,
        )
        if drive is not None and time_ms == 20:
            move = MoveCommand(source=Source.SCRIPT, v_x=drive[0], v_y=drive[1])
            tracker.command(ActuatorCommands(tick=1, time_ms=20, commands=(move,)))
        contacts = ("pusher",) if pressing else ()
        tracker.update(
            WorldState(
                tick=time_ms // 20,
                time_ms=time_ms,
                robot=robot,
                humans=(still, pusher) if time_ms else (pusher,),
                contacts=contacts,
            )
        )
    (episode,) = [e for e in tracker.finish() if e.human == "still"]
    return episode.initiator


def test_a_robot_rolling_on_from_a_push_did_not_initiate() -> None:
    """The push ended before the contact: the robot, commanded nothing or away, rolled on
    (a review found such a contact counted as the robot's)."""
    assert _rolled_into(pushed_ms=400) is Initiator.PUSHED
    assert _rolled_into(pushed_ms=400, drive=(0.2, 0.0)) is Initiator.PUSHED  # away
    assert _rolled_into(pushed_ms=400, drive=(-0.2, 0.0)) is Initiator.ROBOT  # towards them
    assert _rolled_into(pushed_ms=1600) is Initiator.ROBOT  # long after: its own roll


def test_run_and_analysis_say_the_robot_was_pushed_into_the_child(contact_mcaps) -> None:
    """A child walks through a standing robot and pushes it into another child: the run's
    summary and expectation and the analysis of its recording say so alike."""
    result = Session(load_scenario(SCENARIOS / "robot_pushed_into_child.toml")).run()
    assert result.summary.contact_episodes == 2
    assert (result.summary.robot_initiated_contacts, result.summary.pushed_contacts) == (0, 1)
    assert [v.ok for v in result.verdicts] == [True]
    metrics = session_metrics(load_session(contact_mcaps["robot_pushed_into_child"], stream=True))
    initiators = {r["human"]: r["initiator"] for r in metrics["contacts"].rows(named=True)}
    assert initiators == {"pusher": "person", "still": "pushed"}
    (pushed,) = [r for r in metrics["contacts"].rows(named=True) if r["human"] == "still"]
    assert pushed["robot_speed_mps"] == pytest.approx(0.5, abs=0.1)  # faster than the child
    assert metrics.summary["robot_initiated_contacts"].item() == 0
    assert metrics.summary["pushed_contacts"].item() == 1


def test_a_robot_driven_into_the_child_while_pushed_fails_alike_when_checked_again(
    tmp_path: Path,
) -> None:
    """The operator reverses the robot towards the standing child as the other child pushes
    it: its own drive points at them, so the contact is the robot's. The verdict that
    ``oimi analyse`` checks again on the recording must read the move commands too."""
    from oimi.replay.expectations import recorded_verdicts
    from oimi.scenarios.session.recording import recorded

    scenario = tmp_path / "driven.toml"
    scenario.write_text(
        (SCENARIOS / "robot_pushed_into_child.toml").read_text()
        + '\n[[events]]\nat_s = 2.5\nkind = "joystick"\nleft_y = -0.3\nbuttons = ["LB"]'
        + "\nhold_s = 3.0\n"
    )
    session = Session(load_scenario(scenario))
    with recorded(session, mcap=tmp_path / "driven.mcap", rrd=None):
        result = session.run()
    assert (result.summary.robot_initiated_contacts, result.summary.pushed_contacts) == (1, 0)
    assert [(v.name, v.ok, v.detail) for v in result.verdicts] == recorded_verdicts(
        tmp_path / "driven.mcap"
    )
    assert [v.ok for v in result.verdicts] == [False]
