"""One validation of a scenario (issue 15): every bad value the fuzzing found is refused by
``oimi check`` as ``FILE:LINE:COL: field (unit): what``, and by ``run``, ``batch`` and
``--param`` alike; what slips through to a session still fails its verdicts."""

from __future__ import annotations

import math
import re
import typing
from pathlib import Path

import pytest
from oimi.pipeline.events import BodyState, Topic, WorldState
from oimi.scenarios import schema
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.loader import LIBRARY_DIR, LoadedScenario, apply_overrides, load_scenario
from oimi.scenarios.profile import THESIS_ROBOT
from oimi.scenarios.schema import (
    Between,
    HumanSpec,
    MaxSpeed,
    MinDistance,
    Scenario,
    Waypoints,
    unit_of,
)
from oimi.scenarios.session.expectations import Tracker
from oimi.scenarios.session.runner import Session

from oimi.batch.spec import SpecError, expand, toml_literal
from oimi.cli import main

BASE = 'name = "bad"\n'
CHILD = '[[humans]]\nid = "kid"\nx_m = 1.0\ny_m = 1.0\n'

# (what, text after BASE, the message after FILE:LINE:COL, its line)
BAD = [
    (
        "status period zero",
        "[sensors]\nstatus_period_s = 0\n",
        "sensors.status_period_s (s): must be > 0.0, got 0",
        3,
    ),
    (
        "camera rate infinite",
        "[sensors]\nrate_hz = inf\n",
        "sensors.rate_hz (Hz): must be a finite number, got inf",
        3,
    ),
    (
        "camera rate negative",
        "[sensors]\nrate_hz = -1\n",
        "sensors.rate_hz (Hz): must be >= 0.001, got -1",
        3,
    ),
    (
        "camera rate zero",
        "[sensors]\nrate_hz = 0\n",
        "sensors.rate_hz (Hz): must be >= 0.001, got 0",
        3,
    ),
    (
        "robot mass infinite",
        "[robot]\nmass_kg = inf\n",
        "robot.mass_kg (kg): must be a finite number, got inf",
        3,
    ),
    ("duration NaN", "duration_s = nan\n", "duration_s (s): must be a finite number, got nan", 2),
    (
        "event time infinite",
        '[[events]]\nat_s = inf\nkind = "fault"\nsensor = "sonar"\nmode = "frozen"\n',
        "events[0].at_s (s): must be a finite number, got inf",
        3,
    ),
    (
        "hold NaN",
        '[[events]]\nat_s = 1.0\nkind = "joystick"\nhold_s = nan\n',
        "events[0].hold_s (s): must be a finite number, got nan",
        5,
    ),
    (
        "deadline infinite",
        '[[expect]]\nkind = "goal_reached"\ngoal = "g"\nby_s = inf\n',
        "expect[0].by_s (s): must be a finite number, got inf",
        5,
    ),
    (
        "hold beyond a day (its ms overflowed a float)",
        '[[events]]\nat_s = 1.0\nkind = "joystick"\nhold_s = 1e308\n',
        "events[0].hold_s (s): must be <= 86400.0, got 1e+308",
        5,
    ),
    (
        "deadline beyond a day (its ms overflowed a float in the run)",
        '[[expect]]\nkind = "goal_reached"\ngoal = "g"\nby_s = 1e308\n',
        "expect[0].by_s (s): must be <= 86400.0, got 1e+308",
        5,
    ),
    (
        "pause beyond a day",
        CHILD + 'behaviour = [{ kind = "wander", pause_s = 1e308 }]\n',
        "humans[0].behaviour[0].pause_s (s): must be <= 86400.0, got 1e+308",
        6,
    ),
    (
        "battery NaN",
        "[robot]\nbattery_s = nan\n",
        "robot.battery_s (s): must be a finite number, got nan",
        3,
    ),
    (
        "robot limit NaN",
        "[robot]\nmax_angular_speed_radps = nan\n",
        "robot.max_angular_speed_radps (rad/s): must be a finite number, got nan",
        3,
    ),
    (
        "heading infinite",
        "[robot]\ntheta_rad = -inf\n",
        "robot.theta_rad (rad): must be a finite number, got -inf",
        3,
    ),
    (
        "walking speed NaN",
        CHILD + 'behaviour = [{ kind = "approach", speed_mps = nan }]\n',
        "humans[0].behaviour[0].speed_mps (m/s): must be a finite number, got nan",
        6,
    ),
    (
        "waypoint NaN",
        CHILD + 'behaviour = [{ kind = "waypoints", waypoints = [[1.0, nan]] }]\n',
        "humans[0].behaviour[0].waypoints[0][1] (m): must be a finite number, got nan",
        6,
    ),
    (
        "dropout over 1",
        "[sensors]\ndropout_probability = 2.0\n",
        "sensors.dropout_probability (0 to 1): must be <= 1.0, got 2.0",
        3,
    ),
    (
        "negative noise",
        "[sensors]\nnoise_rho_m = -1\n",
        "sensors.noise_rho_m (m): must be >= 0.0, got -1",
        3,
    ),
    (
        "negative fps",
        "[sensors]\ncamera_fps = -30\n",
        "sensors.camera_fps (frames/s): must be >= 1, got -30",
        3,
    ),
    (
        "negative battery",
        "[robot]\nbattery_s = -1\n",
        "robot.battery_s (s): must be >= 0.0, got -1",
        3,
    ),
    (
        "infinite arena",
        "[world]\nwidth_m = inf\n",
        "world.width_m (m): must be a finite number, got inf",
        3,
    ),
    (
        "huge arena",
        "[world]\nheight_m = 1e300\n",
        "world.height_m (m): must be <= 100.0, got 1e+300",
        3,
    ),
    (
        "negative count",
        '[[expect]]\nkind = "rule_fired"\nrule = "r"\nat_most = -1\n',
        "expect[0].at_most (count): must be >= 0, got -1",
        5,
    ),
    (
        "at most below at least",
        '[[expect]]\nkind = "rule_fired"\nrule = "r"\nat_least = 3\nat_most = 2\n',
        "expect[0].at_most (count): 2 is less than at_least (3)",
        6,
    ),
    (
        "a window ending before it starts",
        '[[expect]]\nkind = "rule_fired"\nrule = "r"\nafter_s = 5.0\nby_s = 2.0\n',
        "expect[0].by_s (s): 2.0 is before after_s (5.0)",
        6,
    ),
    (
        "NaN distance threshold",
        '[[expect]]\nkind = "min_distance"\nat_least_m = nan\n',
        "expect[0].at_least_m (m): must be a finite number, got nan",
        4,
    ),
    (
        "NaN speed threshold",
        '[[expect]]\nkind = "max_speed"\nat_most_mps = nan\n',
        "expect[0].at_most_mps (m/s): must be a finite number, got nan",
        4,
    ),
    (
        "stick beyond 1",
        '[[events]]\nat_s = 1.0\nkind = "joystick"\nleft_x = 1.5\n',
        "events[0].left_x (-1 to 1): must be <= 1.0, got 1.5",
        5,
    ),
    (
        "over the robot's ceiling",
        "[robot]\nmax_speed_mps = 10.0\n",
        "robot.max_speed_mps (m/s): 10.0 is above the thesis robot's ceiling of 1.0 m/s"
        " (scenarios/profile.py)",
        3,
    ),
    (
        "unknown generator",
        '[[activities]]\ngenerator = "disco"\n',
        "activities[0].generator: unknown generator 'disco'"
        " (known: example_act, greeting, joint_attention, test_dance)",
        3,
    ),
    (
        "unknown generator option",
        '[[activities]]\ngenerator = "test_dance"\noptions = { speed = "1" }\n',
        "activities[0].options.speed: generator 'test_dance': unknown option 'speed'"
        " (options: tempo, colours, repetitions, track, seed)",
        4,
    ),
    (
        "bad generator option",
        '[[activities]]\ngenerator = "greeting"\noptions = { colour = "plaid" }\n',
        "activities[0].options.colour: generator 'greeting': option 'colour': 'plaid' is not"
        " a colour (red, green, blue, yellow, cyan, magenta, white, orange, purple, pink"
        " or #rrggbb)",
        4,
    ),
    (
        "human inside the robot",
        '[robot]\nx_m = 3.0\ny_m = 2.5\n[[humans]]\nid = "kid"\nx_m = 3.2\ny_m = 2.5\n',
        "humans[0].x_m (m): human 'kid' starts inside the robot (0.2 m between their centres,"
        " less than their radii 0.55 m)",
        7,
    ),
    (
        "escaping script",
        '[[activities]]\nscript = "../../x.txt"\n',
        "activities[0].script: script '../../x.txt' is outside the scenario's folder and the"
        " library (--allow-outside-paths allows it)",
        3,
    ),
    (
        "absolute script",
        '[[activities]]\nscript = "/etc/x.txt"\n',
        "activities[0].script: script '/etc/x.txt' is outside the scenario's folder and the library"
        " (--allow-outside-paths allows it)",
        3,
    ),
]


def test_more_bodies_than_the_map_holds_are_refused_at_the_first_that_does_not_fit(
    tmp_path, capsys
):
    """Past 1024 the map refuses new obstacles: the sonar's echo of a child would be one."""
    obstacle = '[[world.obstacles]]\nid = "o{}"\nx_m = 1.0\ny_m = 1.0\nradius_m = 0.01\n'
    obstacles = "".join(obstacle.format(i) for i in range(1024))
    path = tmp_path / "crowded.toml"
    path.write_text(BASE + obstacles + '[[humans]]\nid = "child"\nx_m = 2.0\ny_m = 2.0\n')
    assert main(["check", str(path)]) == 2
    first = capsys.readouterr().err.splitlines()[0]
    line = 1 + (BASE + obstacles).splitlines().index('id = "o1023"') - 1
    assert first == (
        f"{path}:{line}:1: world.obstacles[1023]: 1024 obstacles and 1 human: the sonar ring"
        " reports each as an obstacle, more than the map holds (1024)"
    )


@pytest.mark.parametrize(("what", "text", "message", "line"), BAD, ids=[b[0] for b in BAD])
def test_check_refuses_the_value_with_its_place_field_and_unit(
    tmp_path, capsys, what, text, message, line
):
    path = tmp_path / "bad.toml"
    path.write_text(BASE + text)
    assert main(["check", str(path)]) == 2, what
    first = capsys.readouterr().err.splitlines()[0]
    assert first.startswith(f"{path}:{line}:"), first
    assert first.split(": ", 1)[1] == message


def test_five_thousand_nested_arrays_are_refused_without_recursing(tmp_path, capsys):
    path = tmp_path / "deep.toml"
    path.write_text(BASE + "x = " + "[" * 5000 + "]" * 5000 + "\n")
    assert main(["check", str(path)]) == 2
    assert capsys.readouterr().err == f"{path}:2:37: TOML: nested deeper than 32 levels\n"


def test_a_script_that_does_not_compile_is_refused_at_its_place(tmp_path, capsys):
    (tmp_path / "broken.txt").write_text("[broken]\n[goal:g]\n[action]\n[b#x#blk_jump: ???]\n")
    path = tmp_path / "s.toml"
    path.write_text(BASE + '[[activities]]\nscript = "broken.txt"\n')
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{path}:3:1: activities[0].script: 'broken.txt' does not load: ")
    assert f"{tmp_path / 'broken.txt'}:4:" in err


def test_outside_paths_are_allowed_with_the_flag(tmp_path, capsys):
    outside = tmp_path / "shared" / "wave.txt"
    outside.parent.mkdir()
    outside.write_text("[wave]\n[goal:g]\n[action]\n[b#one#blk_inst: MV() LD() AO()]\n")
    folder = tmp_path / "scenarios"
    folder.mkdir()
    path = folder / "s.toml"
    path.write_text(BASE + '[[activities]]\nscript = "../shared/wave.txt"\n')
    assert main(["check", str(path)]) == 2
    assert "'../shared/wave.txt' is outside" in capsys.readouterr().err
    assert main(["check", "--allow-outside-paths", str(path)]) == 0
    assert load_scenario(path, allow_outside=True).activity_paths == (
        folder / "../shared/wave.txt",
    )


def test_library_scripts_stay_allowed_from_anywhere(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(BASE + '[[activities]]\nscript = "activities/hold_still.txt"\n')
    assert load_scenario(path).activity_paths == (LIBRARY_DIR / "activities/hold_still.txt",)


# ------------------------------------------------------------------ overrides


def greeting() -> Scenario:
    return load_scenario(LIBRARY_DIR / "greeting.toml").scenario


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        (
            "robot.max_speed_mps",
            "1e300",
            "robot.max_speed_mps (m/s): 1e+300 is above the thesis robot's ceiling of 1.0 m/s",
        ),
        ("robot.max_speed_mps", "nan", "robot.max_speed_mps (m/s): must be a finite number"),
        ("robot.mass_kg", "inf", "robot.mass_kg (kg): must be a finite number, got inf"),
        ("sensors.status_period_s", "0", "sensors.status_period_s (s): must be > 0.0, got 0"),
        ("humans.child.max_speed_mps", "-inf", "humans[0].max_speed_mps (m/s): must be a finite"),
    ],
)
def test_overrides_go_through_the_same_validation(key, value, message):
    with pytest.raises(ScenarioError) as caught:
        apply_overrides(greeting(), {key: value})
    assert str(caught.value).startswith(f"<overrides>: override: {message}")


def test_the_ceiling_is_the_thesis_robot_profile_and_admits_the_defaults():
    robot = greeting().robot
    for name, ceiling in THESIS_ROBOT.ceilings().items():
        assert 0 < getattr(robot, name) <= ceiling, name
        apply_overrides(greeting(), {f"robot.{name}": repr(ceiling)})  # at the ceiling: fine


def test_run_refuses_a_param_over_the_ceiling_before_it_drives(tmp_path, capsys):
    scenario = LIBRARY_DIR / "greeting.toml"
    code = main(["run", str(scenario), "--no-record", "-q", "--param", "robot.max_speed_mps=1e300"])
    assert code == 2
    assert "robot.max_speed_mps (m/s): 1e+300 is above" in capsys.readouterr().err


# ------------------------------------------------------------- verdicts on NaN


def test_a_nan_walking_speed_that_reaches_a_session_leaves_the_child_standing():
    """Built past the loader (a Struct's constructor checks no ranges): the child's NaN speed
    once made NaN positions and 'PASS ... closest inf m'; now the child stands still."""
    child = HumanSpec(
        id="child",
        x_m=1.0,
        y_m=1.0,
        behaviour=[Waypoints(waypoints=[(4.0, 4.0)], speed_mps=math.nan)],
    )
    scenario = Scenario(
        name="nan child",
        duration_s=1.0,
        humans=[child],
        expect=[MinDistance(human="child", at_least_m=0.5)],
    )
    loaded = LoadedScenario(scenario=scenario, source=Path("nan.toml"), raw=b"", activity_paths=())
    result = Session(loaded).run()
    assert result.summary.min_distance_m == {"child": round(math.hypot(2.0, 1.5), 4)}
    assert result.verdicts[0].ok and "nan" not in result.verdicts[0].detail


def test_a_batch_grid_value_must_be_finite():
    with pytest.raises(SpecError, match=r"parameter value nan must be a finite number"):
        toml_literal(math.nan, source="spec.toml")
    with pytest.raises(SpecError, match=r"parameter value \[1.0, inf\] must be a finite"):
        toml_literal([1.0, math.inf], source="spec.toml")


def state(robot_x: float, human_x: float, speed: float = 0.0) -> WorldState:
    return WorldState(
        tick=0,
        time_ms=0,
        robot=BodyState(id="robot", kind="robot", x_m=robot_x, y_m=1.0, vx_mps=speed),
        humans=(BodyState(id="kid", kind="child", x_m=human_x, y_m=1.0),),
    )


@pytest.mark.parametrize(
    ("states", "expectation"),
    [
        ([state(1.0, 3.0), state(math.nan, 3.0), state(1.0, 3.0)], MinDistance(at_least_m=0.5)),
        (
            [state(1.0, 3.0), state(math.nan, 3.0), state(1.0, 3.0)],
            MinDistance(at_least_m=0.5, between=Between.SURFACES),
        ),
        ([state(1.0, math.inf)], MinDistance(human="kid", at_least_m=0.5)),
        ([], MinDistance(human="kid", at_least_m=0.5)),  # never seen: no distance to pass on
        ([state(1.0, 3.0)], MinDistance(at_least_m=math.nan)),
        (
            [state(1.0, 3.0), state(1.0, 3.0, math.nan), state(1.0, 3.0, 0.1)],
            MaxSpeed(at_most_mps=1),
        ),
        ([state(1.0, 3.0, math.inf)], MaxSpeed(at_most_mps=1.0)),
        ([state(1.0, 3.0)], MaxSpeed(at_most_mps=math.nan)),
    ],
)
def test_verdicts_on_nan_or_inf_fail(states, expectation):
    scenario = Scenario(
        name="x", humans=[HumanSpec(id="kid", x_m=3.0, y_m=1.0)], expect=[expectation]
    )
    tracker = Tracker(scenario)
    for message in states:
        tracker.record(Topic.WORLD_STATE, 0, message)
    (verdict,) = tracker.verdicts()
    assert not verdict.ok, verdict


def test_finite_figures_still_pass():
    scenario = Scenario(
        name="x",
        humans=[HumanSpec(id="kid", x_m=3.0, y_m=1.0)],
        expect=[MinDistance(at_least_m=0.5), MaxSpeed(at_most_mps=0.5)],
    )
    tracker = Tracker(scenario)
    tracker.record(Topic.WORLD_STATE, 0, state(1.0, 3.0, 0.4))
    assert [v.ok for v in tracker.verdicts()] == [True, True]


# ------------------------------------------------------------------------- docs

DOC = Path(__file__).resolve().parents[2] / "docs" / "scenario-files.md"


def test_the_doc_states_the_ceiling_of_the_profile():
    rows = re.findall(r"^\| `(\w+)` \| `[\d.]+` \| `([\d.]+)` ([^|]+) \|$", DOC.read_text(), re.M)
    assert {name: float(value) for name, value, _ in rows} == THESIS_ROBOT.ceilings()
    assert all(unit.strip() == unit_of(name) for name, _, unit in rows)


def test_every_number_of_the_schema_is_in_the_doc():
    text = DOC.read_text()
    specs = [v for v in vars(schema).values() if isinstance(v, type) and issubclass(v, schema.Spec)]
    numbers = {
        name
        for spec in specs
        for name, hint in typing.get_type_hints(spec).items()
        if re.search(r"\b(float|int)\b", str(hint))
    }
    missing = [name for name in sorted(numbers) if f"`{name}`" not in text]
    assert len(numbers) > 40 and not missing


@pytest.mark.parametrize("command", [["run", "--no-record", "-q"], ["serve"], ["batch", "-q"]])
def test_every_command_refuses_a_bad_scenario_before_it_starts(tmp_path, capsys, command):
    path = tmp_path / "bad.toml"
    path.write_text(BASE + "[sensors]\nstatus_period_s = 0\n")
    argv = [command[0], str(path), *command[1:]]
    if command[0] == "batch":
        argv += ["--out", str(tmp_path / "out")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"{path}:3:1: sensors.status_period_s (s): must be > 0.0, got 0" in err
    assert not (tmp_path / "out").exists()


def test_batch_tasks_carry_the_outside_paths_flag_to_their_runs(tmp_path):
    (tmp_path / "shared").mkdir()
    (tmp_path / "shared" / "wave.txt").write_text(
        "[wave]\n[goal:g]\n[action]\n[b#one#blk_inst: MV() LD() AO()]\n"
    )
    (tmp_path / "s").mkdir()
    path = tmp_path / "s" / "a.toml"
    path.write_text(BASE + '[[activities]]\nscript = "../shared/wave.txt"\n')
    grid = {"params": {}, "seeds": 1, "seed_range": None, "out_dir": tmp_path / "out"}
    with pytest.raises(ScenarioError, match="is outside the scenario's folder"):
        expand([path], **grid)
    (task,) = expand([path], **grid, allow_outside_paths=True)
    assert task.allow_outside_paths
