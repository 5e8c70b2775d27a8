"""Scenario files' errors: each at its FILE:LINE, saying what is wrong (and, for a name
close to one the scenario knows, which)."""

from __future__ import annotations

import pytest
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.loader import check_scenario, load_scenario
from oimi.scenarios.schema import Scenario

ERRORS = [
    # (what, text, message pattern, line)
    ("unknown key", "[robot]\nx_m = 1.0\nspeed = 2\n", r"robot.speed: unknown field$", 4),
    ("mistyped key", "sead = 3\n", r":2:1: sead: unknown field; did you mean seed\?$", 2),
    (
        "key without its unit",
        "[robot]\nx_m = 1.0\nradius = 0.3\n",
        r"robot.radius: unknown field; did you mean radius_m\?$",
        4,
    ),
    (
        "mistyped key of a tagged table",
        '[[humans]]\nid = "kid"\nx_m = 1.0\ny_m = 1.0\n'
        '[[humans.behaviour]]\nkind = "wander"\npause = 2.0\n',
        r"humans\[0\].behaviour\[0\].pause: unknown field; did you mean pause_s\?$",
        8,
    ),
    (
        "wrong type",
        '[[humans]]\nid = "kid"\nx_m = "left"\ny_m = 1.0\n',
        r"humans\[0\].x_m \(m\): Expected `float`, got `str`$",
        4,
    ),
    (
        "wrong type in the second array table",
        '[[humans]]\nid = "a"\nx_m = 1.0\ny_m = 1.0\n[[humans]]\nid = "b"\nx_m = 1.0\ny_m = []\n',
        r"humans\[1\].y_m \(m\): Expected `float`, got `array`$",
        9,
    ),
    (
        "missing field",
        '[[events]]\nat_s = 1.0\nkind = "touch"\n',
        r"events\[0\].human: required, but missing$",
        2,
    ),
    (
        "unknown tag",
        '[[events]]\nat_s = 1.0\nkind = "dance"\n',
        r"events\[0\].kind: Invalid value 'dance' \(one of operator, joystick, touch, fault,"
        r" behaviour\)$",
        4,
    ),
    (
        "unknown behaviour kind",
        '[[humans]]\nid = "kid"\nx_m = 1.0\ny_m = 1.0\nbehaviour = [{ kind = "waypoint" }]\n',
        r"behaviour\[0\].kind: Invalid value 'waypoint' \(one of stand, waypoints, approach,",
        6,
    ),
    ("TOML syntax", "name = \nseed = 1\n", r"TOML: Invalid value", 2),
    (
        "missing script",
        '[[activities]]\nscript = "activities/none.json"\n',
        r"script file 'activities/none.json' not found",
        3,
    ),
    (
        "mistyped script",
        '[[activities]]\nscript = "activities/cuddle_tme.txt"\n',
        r"not found in the scenario's folder \(/.+\) nor in the library \(/.+/library\);"
        r" did you mean 'activities/cuddle_time.txt'\?$",
        3,
    ),
    ("script kind", '[[activities]]\nscript = "a.py"\n', r"not a .json or .txt file", 3),
    (
        "script without its suffix",
        '[[activities]]\nscript = "example_act"\n',
        r"script 'example_act' is not a .json or .txt file;"
        r" did you mean 'activities/example_act.txt'\?",
        3,
    ),
    (
        "unknown generator",
        '[[activities]]\ngenerator = "disco"\n',
        r"unknown generator 'disco' \(known: example_act, greeting, joint_attention, test_dance\)",
        3,
    ),
    ("neither script nor generator", "[[activities]]\noptions = {}\n", r"exactly one of", 2),
    (
        "event after the end",
        'duration_s = 10.0\n[[events]]\nat_s = 12.0\nkind = "fault"\nsensor = "sonar"\n'
        'mode = "frozen"\n',
        r"event at 12.0 s is outside the session \(0 to 10.0 s\)",
        4,
    ),
    (
        "unknown human in an event",
        '[[events]]\nat_s = 1.0\nkind = "touch"\nhuman = "ghost"\n',
        r"unknown human 'ghost'",
        5,
    ),
    (
        "unknown human in an expectation",
        '[[expect]]\nkind = "min_distance"\nhuman = "ghost"\nat_least_m = 1.0\n',
        r"unknown human 'ghost'",
        4,
    ),
    (
        "waypoint outside the arena",
        '[[humans]]\nid = "kid"\nx_m = 1.0\ny_m = 1.0\n'
        'behaviour = [{ kind = "waypoints", waypoints = [[1.0, 1.0], [9.0, 1.0]] }]\n',
        r"waypoint 1 is at \(9, 1\), outside the arena \(x 0 to 6 m, y 0 to 5 m\)",
        6,
    ),
    (
        "duplicate ids",
        '[[humans]]\nid = "kid"\nx_m = 1.0\ny_m = 1.0\n[[humans]]\nid = "kid"\nx_m = 2.0\n'
        "y_m = 1.0\n",
        r"duplicate id 'kid'",
        7,
    ),
    (
        "unknown sensor id",
        '[[events]]\nat_s = 1.0\nkind = "fault"\nsensor = "camera"\nid = "rear"\n'
        'mode = "offline"\n',
        r"no camera with id 'rear' \(it is 'front'\)",
        6,
    ),
    (
        "segments out of order",
        '[[humans]]\nid = "kid"\nx_m = 1.0\ny_m = 1.0\n[[humans.behaviour]]\nat_s = 5.0\n'
        'kind = "stand"\n[[humans.behaviour]]\nat_s = 2.0\nkind = "stand"\n',
        r"must be in time order",
        10,
    ),
    ("tick rate", "tick_hz = 60\n", r"tick_hz \(Hz\): 60 must divide 1000", 2),
    ("no tick rate", "tick_hz = 0\n", r"tick_hz \(Hz\): must be >= 1, got 0", 2),
    (  # its period sized the supervisor's odometry history: an OverflowError (fuzz, 2413)
        "camera slower than a frame in 1,000 s",
        "[sensors]\nrate_hz = 1e-300\n",
        r"sensors.rate_hz \(Hz\): must be >= 0.001, got 1e-300",
        3,
    ),
    (
        "unknown operator command",
        '[[events]]\nat_s = 1.0\nkind = "operator"\ncommand = { cmd = "strat" }\n',
        r"events\[0\].command.cmd: Invalid value 'strat' \(one of list, add, remove, reorder,",
        5,
    ),
    (
        "operator command without its activity",
        '[[events]]\nat_s = 1.0\nkind = "operator"\ncommand = { cmd = "remove" }\n',
        r"events\[0\].command.activity: required, but missing$",
        5,
    ),
    (
        "operator command with another verb's field",
        '[[events]]\nat_s = 1.0\nkind = "operator"\ncommand = { cmd = "stop", position = 1 }\n',
        r"events\[0\].command.position \(index\): unknown field$",
        5,
    ),
    (
        "operator command with its own id",
        '[[events]]\nat_s = 1.0\nkind = "operator"\ncommand = { cmd = "stop", id = 7 }\n',
        r"events\[0\].command.id: the session numbers the commands: leave id out$",
        5,
    ),
    (
        "operator event in the old flat layout",
        '[[events]]\nat_s = 1.0\nkind = "operator"\nverb = "start"\n',
        r"events\[0\].verb: unknown field; an operator event holds its command: command = \{ cmd",
        5,
    ),
    (
        "a rule_fired expectation with a typo in the rule's name",
        '[[activities]]\nscript = "activities/playroom.txt"\n'
        '[[expect]]\nkind = "rule_fired"\nrule = "child_to_close"\nat_least = 0\nat_most = 0\n',
        r"expect\[0\].rule: no script loads a rule 'child_to_close'; did you mean"
        r" 'child_too_close'\?$",
        6,
    ),
    (
        "an activity expectation with a typo in the activity's name",
        '[[activities]]\ngenerator = "greeting"\n[[expect]]\nkind = "activity_completed"\n'
        'activity = "greting"\n',
        r"expect\[0\].activity: no script is an activity 'greting'; did you mean 'greeting'\?$",
        6,
    ),
    (
        "a goal expectation with a typo in the goal's id",
        '[[activities]]\ngenerator = "greeting"\n[[expect]]\nkind = "goal_reached"\n'
        'goal = "greet_chlid"\n',
        r"expect\[0\].goal: no script has a goal 'greet_chlid'; did you mean 'greet_child'\?$",
        6,
    ),
]


@pytest.mark.parametrize(("what", "text", "pattern", "line"), ERRORS, ids=[e[0] for e in ERRORS])
def test_errors_name_the_file_and_line(tmp_path, what, text, pattern, line):
    path = tmp_path / "bad.toml"
    path.write_text('name = "bad"\n' + text)
    with pytest.raises(ScenarioError, match=pattern) as caught:
        load_scenario(path)
    assert caught.value.line == line, what
    assert str(caught.value).startswith(f"{path}:{line}:")


def test_a_scenario_built_in_code_without_a_tick_rate_is_a_problem_not_a_crash() -> None:
    """The safety checks count in ticks: they wait for a rate that makes whole-ms ticks."""
    problems = list(check_scenario(Scenario(name="t", tick_hz=0)))
    assert (("tick_hz",), "0 must divide 1000 (whole-ms ticks)") in problems
