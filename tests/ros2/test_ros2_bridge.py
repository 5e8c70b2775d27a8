"""``oimi sim --ros2`` and ``oimi bridge`` as two processes over DDS, inside a private network
namespace (nothing can leave it): an activity drives the simulated robot over cmd_vel,
the pad over sensor_msgs/Joy takes over with the lock and stops it on release, and the
bridge's recording replays clean. The operator's side is ``ros2_drive.py``."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("cyclonedds", reason="the ros2 extra (cyclonedds) is not installed")

from oimi.pipeline.events import ActuatorCommands, JoystickInput, Source, Topic
from oimi.pipeline.messages import MoveCommand
from oimi.recorder.reader import open_recording
from oimi.scenarios.real_robot import REAL_SURFACE

from oimi.cli import main

DRIVER = Path(__file__).with_name("ros2_drive.py")
ROOT = Path(__file__).resolve().parents[2]
LIMIT_S = 120
"""The driver's own waits are bounded; this only guards against a hang."""


def _namespace_problem() -> str | None:
    if shutil.which("unshare") is None or shutil.which("ip") is None:
        return "DDS tests run in a private network namespace: unshare or ip is not installed"
    probe = subprocess.run(
        ["unshare", "-n", "ip", "link", "set", "lo", "up"], capture_output=True, text=True
    )
    if probe.returncode != 0:
        return f"cannot make a private network namespace (unshare -n needs root): {probe.stderr}"
    return None


@pytest.fixture(scope="module")
def drive(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path]:
    if problem := _namespace_problem():
        pytest.skip(problem)
    out = tmp_path_factory.mktemp("bridge")
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
    }
    env.pop("CYCLONEDDS_URI", None)
    command = f"ip link set lo up && exec {sys.executable} {DRIVER} {out}"
    done = subprocess.run(
        ["unshare", "-n", "sh", "-c", command],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=LIMIT_S,
    )
    assert done.returncode == 0, done.stderr
    return json.loads((out / "drive.json").read_text()), out


def test_both_processes_meet_over_dds_and_end_cleanly(drive):
    result, _ = drive
    assert result["connected"], result["bridge_stderr"] + result["sim_stderr"]
    assert (result["bridge_exit"], result["sim_exit"]) == (0, 0), result
    assert result["get_ready"] and result["start"]


def test_the_activity_drives_the_simulated_robot_over_cmd_vel(drive):
    result, out = drive
    assert result["script_drives"], result["bridge_stderr"]
    bridge = open_recording(out / "bridge.mcap")
    moves = [
        c
        for m in bridge.iter_messages([Topic.ACTUATOR_COMMANDS])
        for c in m.decoded().commands
        if isinstance(c, MoveCommand)
    ]
    assert moves[0].source is Source.SCRIPT and moves[0].v_x == pytest.approx(0.1)
    assert bridge.summary[Topic.SENSOR_UPDATES.value] > 0  # the sim's sensors, over DDS
    sim = open_recording(out / "sim.mcap")
    states = [m.decoded() for m in sim.iter_messages([Topic.WORLD_STATE])]
    assert max(s.robot.x_m for s in states) > states[0].robot.x_m + 0.005  # it drove forward
    assert any(s.led == pytest.approx((0.0, 0.8, 0.0)) for s in states)  # the script's green


def test_the_pad_takes_over_with_the_lock_and_stops_on_release(drive):
    result, out = drive
    assert result["joystick_turns"] and result["stops_on_release"], result["bridge_stderr"]
    assert result["still_after_release"] == [[0.0, 0.0, 0.0]] * 20
    bridge = open_recording(out / "bridge.mcap")
    pads = [m.decoded() for m in bridge.iter_messages([Topic.JOYSTICK])]
    assert all(isinstance(p, JoystickInput) for p in pads)
    assert [p.buttons for p in pads] == [("LB",), ()]
    assert pads[0].right_x == 1.0  # joy_node's axis 3, left positive, read back
    commands = [
        (m.tick, c)
        for m in bridge.iter_messages([Topic.ACTUATOR_COMMANDS])
        if isinstance(e := m.decoded(), ActuatorCommands)
        for c in e.commands
        if isinstance(c, MoveCommand)
    ]
    by_pad = [(t, c) for t, c in commands if c.source is Source.JOYSTICK]
    assert by_pad and by_pad[0][0] == pads[0].tick and by_pad[0][1].v_theta < 0
    stops = [(t, c) for t, c in commands if c.source is Source.SAFETY]
    assert stops[0][0] == pads[1].tick and stops[0][1].stop
    assert all(c.source is not Source.SCRIPT for t, c in commands if t > pads[1].tick)


def test_the_bridge_recording_replays_clean(drive):
    _, out = drive
    assert main(["replay", str(out / "bridge.mcap"), "--mode", "redrive"]) == 0


def test_the_bridge_takes_a_lab_cameras_range_left_out_for_3_m_and_records_it(drive):
    """``ros2_room.toml`` gives its camera's view, not its range: the bridge warns and its
    supervisor takes its own 3 m (a child beyond the lab tracker's range is never reported),
    recorded as the session's variation: the redrive above rebuilds the same supervisor."""
    result, out = drive
    assert "sensors.range_m (m): not set: the safety supervisor takes" in result["bridge_stderr"]
    variation = open_recording(out / "bridge.mcap").meta.variation
    assert variation == {"robot.safety.camera_range_m": "3.0"} | REAL_SURFACE


def test_the_bridge_takes_a_ring_left_unsaid_for_centres_and_records_it(drive):
    """``ros2_room.toml`` does not say whether its ring's echoes are surfaces (the
    simulated ring's are): the bridge warns, and its supervisor takes them for what may be
    centres (``sonar_reports_surface`` false: covers either), recorded as the variation."""
    result, out = drive
    warned = "robot.safety.sonar_reports_surface: not set: the safety supervisor takes"
    assert warned in result["bridge_stderr"]
    assert open_recording(out / "bridge.mcap").meta.variation.items() >= REAL_SURFACE.items()


def test_the_simulated_robot_stands_still_when_cmd_vel_falls_silent(drive):
    result, _ = drive
    assert result["moves_again"], result["sim_stderr"]
    assert result["silence_stops"], result["sim_stderr"]
    assert "no cmd_vel for 500 ms: standing still" in result["sim_stderr"]


def test_the_bridge_refuses_a_scenario_that_assumes_less_of_people_than_the_supervisor(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Before any port, DDS participant or recording is opened (nothing is sent: no
    namespace needed)."""

    def no_dds(*args: object, **kwargs: object) -> None:
        raise AssertionError("a DDS participant was opened")

    monkeypatch.setattr("oimi.ros2.bridge.Node", no_dds)
    scenario = tmp_path / "lab.toml"
    scenario.write_text('name = "lab"\n[robot.safety]\nhuman_speed_mps = 0.3\n')
    output = tmp_path / "lab.mcap"
    command = ["bridge", str(scenario), "-o", str(output), "--no-console", "--no-tcp"]
    assert main(command) == 2
    error = capsys.readouterr().err
    assert f"{scenario}:3:1: robot.safety.human_speed_mps (m/s): 0.3 is below" in error
    assert not output.exists()
