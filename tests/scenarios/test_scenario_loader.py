"""Scenario files: decoding, defaults, errors at FILE:LINE, overrides."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from oimi.pipeline.operator.commands import Add
from oimi.pipeline.operator.generator import Catalogue
from oimi.pipeline.operator.generators import DanceGenerator
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.loader import apply_overrides, load_scenario, parse_scenario
from oimi.scenarios.schema import (
    Approach,
    BehaviourEvent,
    FaultEvent,
    FaultMode,
    GoalReached,
    JoystickEvent,
    MinDistance,
    OperatorEvent,
    Role,
    Stand,
    TouchEvent,
    Wander,
    Waypoints,
)

from oimi.cli import main

DOC = Path(__file__).resolve().parents[2] / "docs" / "scenario-files.md"


def test_a_minimal_scenario_gets_every_default():
    loaded = parse_scenario(b'name = "empty room"\n')
    scenario = loaded.scenario
    assert scenario.name == "empty room"
    assert (scenario.seed, scenario.duration_s, scenario.tick_hz) == (0, 60.0, 50)
    assert (scenario.tick_ms, scenario.ticks) == (20, 3000)
    assert scenario.robot.radius_m == 0.3
    assert scenario.robot.max_speed_mps == 0.5
    assert scenario.sensors.range_m == 5.0
    assert scenario.humans == [] and scenario.events == [] and scenario.expect == []
    assert loaded.raw == b'name = "empty room"\n'


FULL = """
name = "ball game"
description = "The child plays ball while the therapist watches."
seed = 42
duration_s = 30.0
tick_hz = 100

[world]
width_m = 7.0
height_m = 5.5
obstacles = [
  { id = "table", kind = "table", x_m = 1.0, y_m = 4.5, width_m = 1.2, height_m = 0.8 },
  { id = "stool", kind = "chair", x_m = 6.0, y_m = 1.0, radius_m = 0.25 },
]
objects = [{ id = "ball", category = "ball", x_m = 3.0, y_m = 2.0, istarget = true }]

[robot]
x_m = 3.5
y_m = 3.0
theta_rad = 1.57
max_speed_mps = 0.4

[sensors]
noise_rho_m = 0.02
dropout_probability = 0.05

[[humans]]
id = "child"
x_m = 1.0
y_m = 1.0
behaviour = [
  { kind = "wander", speed_mps = 0.6 },
  { at_s = 10.0, kind = "approach", distance_m = 0.9 },
]

[[humans]]
id = "therapist"
role = "therapist"
x_m = 6.0
y_m = 4.0

[[humans.behaviour]]
kind = "waypoints"
waypoints = [[5.0, 4.0], [5.0, 3.0]]

[[activities]]
script = "activities/wave.txt"

[[activities]]
generator = "test_dance"
options = { tempo = "slow" }

[[events]]
at_s = 1.0
kind = "operator"
command = { cmd = "add", activity = "test_dance" }

[[events]]
at_s = 2.0
kind = "joystick"
left_y = 0.5
buttons = ["LB"]
hold_s = 1.0

[[events]]
at_s = 3.0
kind = "touch"
human = "child"
touchtype = "H"
duration_ms = 1200

[[events]]
at_s = 4.0
kind = "fault"
sensor = "camera"
mode = "offline"

[[events]]
at_s = 5.0
kind = "behaviour"
human = "therapist"
segment = { kind = "stand" }

[[expect]]
kind = "goal_reached"
goal = "greet"
by_s = 20.0

[[expect]]
kind = "min_distance"
human = "child"
at_least_m = 0.5

[[expect]]
kind = "no_rejected_inputs"
"""


def write(folder: Path, text: str, name: str = "scenario.toml") -> Path:
    path = folder / name
    path.write_text(text)
    (folder / "activities").mkdir(exist_ok=True)
    (folder / "activities" / "wave.txt").write_text(WAVE)
    return path


WAVE = """[wave]
[goal:hello]
[action]
[b#one#blk_inst: MV() LD("1, 1, 0, 1, 0, 500") AO()]
[b#end#blk_terminus]
"""


def test_a_full_scenario_decodes_into_typed_structs(tmp_path):
    path = write(tmp_path, FULL)
    loaded = load_scenario(path)
    scenario = loaded.scenario
    assert loaded.source == path
    assert loaded.raw == path.read_bytes()
    assert loaded.activity_paths == (tmp_path / "activities" / "wave.txt", None)
    assert scenario.tick_ms == 10
    assert [o.id for o in scenario.world.obstacles] == ["table", "stool"]
    assert scenario.world.objects[0].istarget
    assert scenario.humans[0].behaviour == [
        Wander(speed_mps=0.6),
        Approach(at_s=10.0, distance_m=0.9),
    ]
    assert scenario.humans[1].role is Role.THERAPIST
    assert scenario.humans[1].behaviour == [Waypoints(waypoints=[(5.0, 4.0), (5.0, 3.0)])]
    assert scenario.activities[1].options == {"tempo": "slow"}
    assert [type(e) for e in scenario.events] == [
        OperatorEvent,
        JoystickEvent,
        TouchEvent,
        FaultEvent,
        BehaviourEvent,
    ]
    assert scenario.events[0].command == Add(activity="test_dance")
    assert scenario.events[3].mode is FaultMode.OFFLINE
    assert scenario.events[4].segment == Stand()
    assert scenario.expect[0] == GoalReached(goal="greet", by_s=20.0)
    assert scenario.expect[1] == MinDistance(human="child", at_least_m=0.5)


def test_a_rule_named_by_no_script_nor_like_one_is_left_to_the_generators(tmp_path):
    path = tmp_path / "free.toml"
    path.write_text(
        'name = "free"\n[[activities]]\ngenerator = "greeting"\n'
        '[[expect]]\nkind = "rule_fired"\nrule = "made_by_some_generator"\nat_least = 0\n'
    )
    assert load_scenario(path).scenario.expect[0].rule == "made_by_some_generator"


def test_error_column_points_at_the_key():
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(b'name = "x"\n[robot]\n  max_speed_mps = "fast"\n', source="s.toml")
    assert str(caught.value) == "s.toml:3:3: robot.max_speed_mps (m/s): Expected `float`, got `str`"


def test_generators_are_checked_against_the_catalogue_given():
    loaded = parse_scenario(
        b'name = "x"\n[[activities]]\ngenerator = "anything"\n',
        catalogue=Catalogue({"anything": lambda: DanceNamed("anything")}),
    )
    assert loaded.activity_paths == (None,)


class DanceNamed(DanceGenerator):
    def __init__(self, name: str):
        super().__init__()
        self.name = name


def test_scripts_are_found_in_the_library(tmp_path, monkeypatch):
    library = tmp_path / "library"
    (library / "activities").mkdir(parents=True)
    (library / "activities" / "hello.txt").write_text(WAVE)
    monkeypatch.setattr("oimi.scenarios.loader.LIBRARY_DIR", library)
    text = b'name = "x"\n[[activities]]\nscript = "activities/hello.txt"\n'
    loaded = parse_scenario(text, source=tmp_path / "elsewhere" / "s.toml")
    assert loaded.activity_paths == (library / "activities" / "hello.txt",)


def test_an_unreadable_file_is_a_scenario_error(tmp_path):
    with pytest.raises(ScenarioError, match="cannot read the scenario"):
        load_scenario(tmp_path / "missing.toml")


def test_overrides_are_typed_by_the_schema():
    scenario = _full()
    changed = apply_overrides(
        scenario,
        {
            "robot.max_speed_mps": "0.3",
            "seed": "7",
            "humans.child.x_m": "2",
            "humans.1.role": "child",
            "world.objects.ball.istarget": "false",
        },
    )
    assert changed.robot.max_speed_mps == 0.3
    assert changed.seed == 7
    assert changed.humans[0].x_m == 2.0
    assert changed.humans[1].role is Role.CHILD
    assert changed.world.objects[0].istarget is False
    assert scenario.robot.max_speed_mps == 0.4  # the original is untouched


def _full():
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        return load_scenario(write(Path(folder), FULL)).scenario


@pytest.mark.parametrize(
    ("overrides", "pattern"),
    [
        ({"robot.top_speed": "1"}, r"override 'robot.top_speed': no field 'top_speed'"),
        ({"humans.ghost.x_m": "1"}, r"no element 'ghost'"),
        ({"robot.max_speed_mps": "fast"}, r"robot.max_speed_mps \(m/s\): Expected `float`, got"),
        (
            {"humans.child.x_m": "99"},
            r"human 'child' starts at \(99, 1\), outside the arena \(x 0 to 7 m",
        ),
    ],
)
def test_bad_overrides_are_scenario_errors(overrides, pattern):
    with pytest.raises(ScenarioError, match=pattern):
        apply_overrides(_full(), overrides)


def test_the_documented_example_passes_oimi_check(tmp_path, capsys):
    text = DOC.read_text()
    example = re.search(r"```toml\n(.*?)```", text, re.S)
    assert example, "docs/scenario-files.md has a ```toml example"
    path = tmp_path / "example.toml"
    path.write_text(example.group(1))
    assert main(["check", str(path)]) == 0, capsys.readouterr().err
    assert capsys.readouterr().out == f"{path}: ok\n"
    loaded = load_scenario(path)
    scenario = loaded.scenario
    assert scenario.humans and scenario.events and scenario.expect and scenario.activities
    kinds = {type(e).__name__ for e in scenario.events}
    assert kinds == {"OperatorEvent", "JoystickEvent", "TouchEvent", "FaultEvent", "BehaviourEvent"}


INLINE = """name = "inline"
[[humans]]
id = "kid"
x_m = 1.0
y_m = 1.0
behaviour = [
  { kind = "stand" },
  { at_s = 2.0, kind = "waypoints", waypoints = [[1.0, 1.0], [1.0, 7.5]] },
  { at_s = 4.0, kind = "approach", distance_m = "near" },
]
"""


def test_errors_inside_inline_tables_point_at_the_element_key():
    with pytest.raises(ScenarioError) as caught:
        parse_scenario(INLINE.encode(), source="s.toml")
    assert str(caught.value).startswith(
        "s.toml:9:36: humans[0].behaviour[2].distance_m (m): Expected `float`, got `str`"
    )


def test_a_waypoint_outside_the_arena_is_placed_on_the_waypoint():
    text = INLINE.replace('"near"', "0.5")
    with pytest.raises(ScenarioError, match=r"waypoint 1 is at \(1, 7.5\), outside") as caught:
        parse_scenario(text.encode(), source="s.toml")
    assert (caught.value.line, caught.value.column) == (8, 62)
