"""Recordings for the analysis tests: short scenarios run once per test session."""

from __future__ import annotations

from pathlib import Path

import pytest
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.recording import recorded
from oimi.scenarios.session.runner import Session

LIBRARY = Path(__file__).resolve().parents[2] / "scenarios" / "library"

WALK_AT_ROBOT = """
name = "walk at robot"
seed = 0
duration_s = 10.0

[robot]
x_m = 1.0
y_m = 2.5

[[humans]]
id = "child"
x_m = 5.0
y_m = 2.5
behaviour = [{ kind = "waypoints", waypoints = [[1.8, 2.5]], speed_mps = 0.5 }]
"""
"""No activity: the robot stays put while a child walks straight at it from 4 m to 0.8 m
at 0.5 m/s, crossing the social (3.6 m) and personal (1.2 m) zone borders."""


def _record(scenario: Path, mcap: Path) -> Path:
    session = Session(load_scenario(scenario))
    with recorded(session, mcap=mcap, rrd=None):
        session.run()
    return mcap


@pytest.fixture(scope="session")
def recordings_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("analysis_recordings")
    walk = folder / "walk_at_robot.toml"
    walk.write_text(WALK_AT_ROBOT)
    sessions = folder / "sessions"
    _record(walk, sessions / "walk.mcap")
    _record(LIBRARY / "child_too_close.toml", sessions / "child_too_close.mcap")
    _record(LIBRARY / "joystick_takeover.toml", sessions / "joystick_takeover.mcap")
    return sessions


@pytest.fixture(scope="session")
def walk_mcap(recordings_dir: Path) -> Path:
    return recordings_dir / "walk.mcap"


@pytest.fixture(scope="session")
def too_close_mcap(recordings_dir: Path) -> Path:
    return recordings_dir / "child_too_close.mcap"


@pytest.fixture(scope="session")
def joystick_mcap(recordings_dir: Path) -> Path:
    return recordings_dir / "joystick_takeover.mcap"


SCENARIOS = Path(__file__).resolve().parent / "scenarios"


@pytest.fixture(scope="session")
def contact_mcaps(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The contact scenarios of ``tests/analysis/scenarios``, recorded."""
    folder = tmp_path_factory.mktemp("contacts")
    return {
        name: _record(SCENARIOS / f"{name}.toml", folder / f"{name}.mcap")
        for name in ("scripted_collision", "child_walks_into_robot", "robot_pushed_into_child")
    }
