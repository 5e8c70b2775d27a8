"""A session of the safety property (``test_safety_property.py``): a trial's scenario (what
drives the robot, the people, the sensors, a hostile rule), run whole and recorded."""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

from oimi.pipeline.sink import MemorySink
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.runner import Session

from tests.scenarios.hostile_rules import TAMPERING
from tests.scenarios.session_record import TICK_MS, Ran

DURATION_S = 5.0


class Trial(NamedTuple):
    """One session of a property: what drives the robot, the people (a speed of 0: standing
    where they start), the camera, a hostile rule, the sensors' faults."""

    pads: Sequence
    moves: Sequence
    humans: Sequence
    heading: float
    all_round: bool = True
    tamper: int | None = None
    faults: Sequence = ()
    beams: int = 0
    """The ring's sonars (``sonar_beams``; 0: the ideal ring, every body apart)."""
    dropout: float = 0.0
    """Each reading's chance of being lost (``[sensors] dropout_probability``)."""
    reach: float | None = None
    """The camera's range (``[sensors] range_m``; None: 20 m seeing all round, else 5 m)."""


def scenario_text(trial: Trial) -> str:
    pads, moves, humans, heading, all_round, tamper, faults, beams, dropout, reach = trial
    lines = [
        'name = "safety property"',
        *(['extensions = ["tamper.py"]'] if tamper is not None else []),
        f"duration_s = {DURATION_S}",
        "[world]",
        "width_m = 12.0",
        "height_m = 12.0",
        "[robot]",
        "x_m = 6.0",
        "y_m = 6.0",
        f"theta_rad = {heading}",
        "[sensors]",
        f"sonar_beams = {beams}",
        *([f"dropout_probability = {dropout}"] if dropout else []),
        *(["fov_rad = 6.3"] if all_round else []),
        *([f"range_m = {reach}"] if reach else ["range_m = 20.0"] if all_round else []),
    ]
    for i, (start, waypoints, speed) in enumerate(humans):
        points = ", ".join(f"[{x}, {y}]" for x, y in waypoints)
        walk = f'kind = "waypoints", waypoints = [{points}], speed_mps = {speed}'
        walk = walk if speed else 'kind = "stand"'
        lines += [
            "[[humans]]",
            f'id = "h{i}"',
            f"x_m = {start[0]}",
            f"y_m = {start[1]}",
            f"behaviour = [{{ {walk} }}]",
        ]
    for at_s, sensor, mode in faults:
        lines += ["[[events]]", 'kind = "fault"', f"at_s = {at_s}", f'sensor = "{sensor}"']
        lines.append(f'mode = "{mode}"')
    if moves or tamper is not None:
        lines += ["[[activities]]", 'script = "activities/moves.txt"']
    at_tick = 5
    for held, left_x, left_y, right_x, buttons in pads:
        if at_tick * TICK_MS >= DURATION_S * 1000:
            break  # the pad's later states fall after the session (a scenario refuses them)
        lines += [
            "[[events]]",
            'kind = "joystick"',
            f"at_s = {at_tick * TICK_MS / 1000}",
            f"left_x = {left_x}",
            f"left_y = {left_y}",
            f"right_x = {right_x}",
            f"buttons = {list(buttons)!r}".replace("'", '"'),
        ]
        at_tick += held
    return "\n".join(lines) + "\n"


def script_text(moves, tamper: int | None = None) -> str:
    lines = ["[moves]"]
    if tamper is not None:
        lines.append(f'[alfa:{tamper}, tamper, "", "", A, U]')
    lines += ["[goal:drive]", "[action]"]
    for i, (v_x, v_y, v_theta, duration) in enumerate(moves):
        lines.append(f'[b#m{i}#blk_inst: MV("{v_x}, {v_y}, {v_theta}, 0, {duration}") LD() AO()]')
    if not moves:
        lines.append('[b#lit#blk_inst: MV() LD("0, 0, 1, 1, 0, 100") AO()]')
    lines.append("[b#end#blk_terminus]")
    return "\n".join(lines) + "\n"


def run_session(trial: Trial) -> Ran:
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        (root / "activities").mkdir()
        (root / "activities" / "moves.txt").write_text(script_text(trial.moves, trial.tamper))
        (root / "tamper.py").write_text(TAMPERING)
        (root / "property.toml").write_text(scenario_text(trial))
        loaded = load_scenario(root / "property.toml")
        session = Session(loaded)
        memory = MemorySink()
        session.sink.add(memory)
        session.run()
    safety = session.pipeline.config.safety
    walk = safety.human_speed_mps
    echo_ms = max(safety.max_data_age_ms, safety.echo_hold_ms)  # type: ignore[type-var]
    covered = walk * safety.max_data_age_ms / 1000  # type: ignore[operator]
    return Ran(memory, covered, walk * echo_ms / 1000, safety)
