"""Tables 4.1/4.2: each attribute decodes its payload; each fault is named."""

from __future__ import annotations

import re

import msgspec
import pytest
from oimi.pipeline.messages import (
    AudioStatus,
    GoalEvent,
    LedStatus,
    MapUpdate,
    Policy,
    Pose,
    SpeedStatus,
    Touch,
    Tracking,
)
from oimi.pipeline.sense.script_names import check_script_path, check_script_root
from oimi.pipeline.sense.updates import (
    UPDATE_TABLE,
    EntityClass,
    MapUpdateError,
    ScriptVect,
    Storage,
    Target,
    decode_update,
    parse_objectid,
)

POSE = '{"positionrho": 1.5, "positiontheta": -0.25, "positionchangetime": 40}'
TRACK = '{"permanencetime": 300, "appearanceon": 20}'


def upd(objectid: str, attr: str, jsonmsg: str, policy: Policy = Policy.R) -> MapUpdate:
    return MapUpdate(objectid=objectid, attributename=attr, policy=policy, jsonmsg=jsonmsg, seq=7)


# (objectid, attribute, jsonmsg, decoded value)
VALID = [
    ("Camera/front", "isonline", "s_true", True),
    ("Camera/front", "isonline", "s_false", False),
    ("Camera/front", "width", "640", 640),
    ("Camera/front", "height", "480", 480),
    ("Camera/front", "fps", "30", 30),
    ("Camera/front", "frametime", "2400", 2400),
    ("Sonar/s1", "isonline", "s_true", True),
    ("Sonar/s1", "scanfrequency", "10", 10),
    ("Sonar/s1", "scantime", "2400", 2400),
    ("Human/3", "poses", POSE, Pose(positionrho=1.5, positiontheta=-0.25, positionchangetime=40)),
    ("Human/3", "tracking", TRACK, Tracking(permanencetime=300, appearanceon=20)),
    (
        "Obstacle/wall",
        "poses",
        POSE,
        Pose(positionrho=1.5, positiontheta=-0.25, positionchangetime=40),
    ),
    ("Obstacle/wall", "tracking", TRACK, Tracking(permanencetime=300, appearanceon=20)),
    ("Obstacle/wall", "isfixed", "s_false", False),
    (
        "Object/ball",
        "poses",
        POSE,
        Pose(positionrho=1.5, positiontheta=-0.25, positionchangetime=40),
    ),
    ("Object/ball", "tracking", TRACK, Tracking(permanencetime=300, appearanceon=20)),
    ("Object/ball", "istarget", "s_true", True),
    ("Object/ball", "category", "toy ball", "toy ball"),
    ("RobotStatus", "batterytimeleft", "3600000", 3600000),
    (
        "RobotStatus",
        "touch",
        '{"touchtype": "H", "duration": 500, "startingtime": 100}',
        Touch(touchtype="H", duration=500, startingtime=100),
    ),
    (
        "RobotStatus",
        "led",
        '{"r": 0, "g": 0.5, "b": 1, "frequency": 2, "duration": 1000, "startingtime": 5}',
        LedStatus(r=0.0, g=0.5, b=1.0, frequency=2, duration=1000, startingtime=5),
    ),
    (
        "RobotStatus",
        "audioout",
        '{"duration": 2000, "startingtime": 0, "trackpath": "hi.ogg"}',
        AudioStatus(duration=2000, startingtime=0, trackpath="hi.ogg"),
    ),
    ("RobotStatus", "audioin", "hello robot", "hello robot"),
    (
        "RobotStatus",
        "speed",
        '{"xspeed": 0.2, "yspeed": 0, "thetaspeed": -1, "duration": 100, "startingtime": 123}',
        SpeedStatus(xspeed=0.2, yspeed=0.0, thetaspeed=-1.0, duration=100, startingtime=123),
    ),
    ("RobotStatus/robot", "elapsedtime", "1000", 1000),
    (
        "RobotStatus/robot",
        "goalreached",
        '{"goalid": "g1", "timestamp": 9}',
        GoalEvent(goalid="g1", timestamp=9),
    ),
    (
        "RobotStatus/robot",
        "goalfailed",
        '{"goalid": "g1", "timestamp": 9}',
        GoalEvent(goalid="g1", timestamp=9),
    ),
    (
        "RobotStatus/robot",
        "goalinterrupted",
        '{"goalid": "g1", "timestamp": 9}',
        GoalEvent(goalid="g1", timestamp=9),
    ),
    ("RobotStatus/robot", "startingtime", "0", 0),
    ("Script", "submove", "2", 2),
    ("Script", "subled", "0", 0),
    ("Script", "subaout", "1", 1),
    (
        "Script",
        "script_vect",
        '{"restart": "s_true", "update": ["activities/a.json"]}',
        ScriptVect(restart=True, paths=("activities/a.json",)),
    ),
]


@pytest.mark.parametrize(("objectid", "attr", "jsonmsg", "value"), VALID)
def test_each_table_attribute_decodes_its_payload(objectid, attr, jsonmsg, value):
    decoded = decode_update(upd(objectid, attr, jsonmsg))
    assert decoded.value == value
    assert decoded.spec.name == attr


def test_valid_cases_cover_every_row_of_the_tables():
    covered = {(parse_objectid(o).klass, a) for o, a, _, _ in VALID}
    rows = {(k, a) for k, attrs in UPDATE_TABLE.items() for a in attrs}
    assert covered == rows


def test_appendable_rows_allow_r_and_a_others_only_r():
    for attrs in UPDATE_TABLE.values():
        for spec in attrs.values():
            expected = (Policy.R, Policy.A) if spec.storage is Storage.APPENDABLE else (Policy.R,)
            assert spec.policies == expected, spec.name


def test_appendable_attribute_accepts_policy_a():
    assert decode_update(upd("Human/3", "poses", POSE, Policy.A)).update.policy is Policy.A


@pytest.mark.parametrize(
    ("objectid", "target"),
    [
        ("Human/3", Target(klass=EntityClass.HUMAN, id="3")),
        ("Human\\3", Target(klass=EntityClass.HUMAN, id="3")),
        ("Camera/front-left", Target(klass=EntityClass.CAMERA, id="front-left")),
        ("RobotStatus", Target(klass=EntityClass.ROBOT_STATUS)),
        ("RobotStatus/any", Target(klass=EntityClass.ROBOT_STATUS)),
        ("Script", Target(klass=EntityClass.SCRIPT)),
        ("Script\\main", Target(klass=EntityClass.SCRIPT)),
    ],
)
def test_objectid_accepts_both_separators_and_optional_singleton_ids(objectid, target):
    assert parse_objectid(objectid) == target


# (objectid, attribute, policy, jsonmsg, expected reason pattern)
REJECTED = [
    ("Robot/1", "poses", Policy.R, POSE, r"unknown class 'Robot' \(expected one of Camera"),
    ("", "poses", Policy.R, POSE, r"unknown class ''"),
    ("human/1", "poses", Policy.R, POSE, r"unknown class 'human'"),
    ("Human", "poses", Policy.R, POSE, r"class Human needs an ID"),
    ("Human/", "poses", Policy.R, POSE, r"class Human needs an ID"),
    ("Human/a b", "poses", Policy.R, POSE, r"bad ID 'a b'"),
    ("Human/a/b", "poses", Policy.R, POSE, r"bad ID 'a/b'"),
    (
        "Human/3",
        "width",
        Policy.R,
        "1",
        r"Human/3\.width: unknown attribute 'width' for class "
        r"Human \(expected one of poses, tracking\)",
    ),
    (
        "Camera/1",
        "isonline",
        Policy.A,
        "s_true",
        r"Camera/1\.isonline: policy A not allowed \(allowed: R\)",
    ),
    (
        "Script",
        "script_vect",
        Policy.A,
        '{"restart": "s_true", "update": []}',
        r"policy A not allowed",
    ),
    ("Camera/1", "isonline", Policy.R, "true", r"expected 's_true' or 's_false', got 'true'"),
    ("Camera/1", "isonline", Policy.R, '"s_true"', r"expected 's_true' or 's_false'"),
    ("Camera/1", "width", Policy.R, "12.5", r"decimal integer, got '12\.5'"),
    ("Camera/1", "width", Policy.R, "-3", r"decimal integer, got '-3'"),
    ("Camera/1", "width", Policy.R, " 3", r"decimal integer"),
    ("Camera/1", "width", Policy.R, "", r"decimal integer, got ''"),
    ("Camera/1", "fps", Policy.R, "٣", r"decimal integer"),
    ("Camera/1", "fps", Policy.R, "9" * 20, r"out of range"),
    ("Human/3", "poses", Policy.R, POSE + '"', r"bad jsonmsg: JSON is malformed"),
    ("Human/3", "poses", Policy.R, "{positionrho: 1}", r"JSON is malformed"),
    ("Human/3", "poses", Policy.R, "[1, 2]", r"Expected `object`, got `array`"),
    (
        "Human/3",
        "poses",
        Policy.R,
        '{"positionrho": "1", "positiontheta": 0, "positionchangetime": 1}',
        r"Expected `float`, got `str` - at `\$\.positionrho`",
    ),
    (
        "Human/3",
        "poses",
        Policy.R,
        '{"positionrho": 1, "positiontheta": 0, "positionchangetime": 1.5}',
        r"Expected `int`, got `float` - at `\$\.positionchangetime`",
    ),
    (
        "Human/3",
        "poses",
        Policy.R,
        '{"positionrho": -1, "positiontheta": 0, "positionchangetime": 1}',
        r"Expected `float` >= 0\.0 - at `\$\.positionrho`",
    ),
    (
        "Human/3",
        "poses",
        Policy.R,
        '{"positionrho": 1, "positiontheta": 0}',
        r"missing required field `positionchangetime`",
    ),
    (
        "Object/b",
        "tracking",
        Policy.A,
        '{"permanencetime": 1, "appearanceon": 2, "x": 3}',
        r"unknown field `x`",
    ),
    (
        "Obstacle/w",
        "tracking",
        Policy.A,
        '{"permanencetime": true, "appearanceon": 2}',
        r"Expected `int`, got `bool`",
    ),
    (
        "RobotStatus",
        "touch",
        Policy.A,
        '{"touchtype": "X", "duration": 1, "startingtime": 1}',
        r"Invalid enum value 'X' - at `\$\.touchtype`",
    ),
    (
        "RobotStatus",
        "led",
        Policy.A,
        '{"r": 255, "g": 0, "b": 0, "frequency": 1, "duration": 1, "startingtime": 1}',
        r"Expected `float` <= 1\.0 - at `\$\.r`",
    ),
    (
        "RobotStatus",
        "audioout",
        Policy.A,
        '{"duration": 1, "startingtime": 1, "trackpath": ""}',
        r"Expected `str` of length >= 1 - at `\$\.trackpath`",
    ),
    (
        "RobotStatus",
        "speed",
        Policy.A,
        '{"xspeed": 1e999, "yspeed": 0, "thetaspeed": 0, "duration": 1, "startingtime": 1}',
        r"Number out of range - at `\$\.xspeed`",
    ),
    (
        "RobotStatus",
        "goalreached",
        Policy.A,
        '{"goalid": 3, "timestamp": 1}',
        r"Expected `str`, got `int` - at `\$\.goalid`",
    ),
    (
        "Script",
        "script_vect",
        Policy.R,
        '{"restart": true, "update": []}',
        r"Expected `str`, got `bool` - at `\$\.restart`",
    ),
    (
        "Script",
        "script_vect",
        Policy.R,
        '{"restart": "s_true", "update": "activities/a.json"}',
        r"Expected `array`, got `str` - at `\$\.update`",
    ),
    (
        "Script",
        "script_vect",
        Policy.R,
        '{"restart": "s_true", "update": ["/etc/passwd"]}',
        r"Script\.script_vect: at `\$\.update\[0\]`: path '/etc/passwd' is absolute",
    ),
    (
        "Script",
        "script_vect",
        Policy.R,
        '{"restart": "s_false", "update": ["activities/a.json", "activities/../../x.json"]}',
        r"at `\$\.update\[1\]`: path 'activities/\.\./\.\./x\.json' contains '\.\.'",
    ),
]


@pytest.mark.parametrize(("objectid", "attr", "policy", "jsonmsg", "reason"), REJECTED)
def test_invalid_update_is_rejected_with_a_reason(objectid, attr, policy, jsonmsg, reason):
    with pytest.raises(MapUpdateError, match=reason):
        decode_update(upd(objectid, attr, jsonmsg, policy))


@pytest.mark.parametrize(
    ("path", "problem"),
    [
        ("", r"path is empty"),
        ("/activities/a.json", r"is absolute"),
        ("//activities/a.json", r"is absolute"),
        ("activities/../a.json", r"contains '\.\.'"),
        ("..", r"contains '\.\.'"),
        ("activities\\..\\a.json", r"contains a backslash"),
        ("activities\\a.json", r"contains a backslash"),
        ("activities/./a.json", r"not normalised \(expected 'activities/a\.json'\)"),
        ("./activities/a.json", r"not normalised"),
        ("activities//a.json", r"not normalised"),
        ("activities/sub/", r"not normalised"),
        ("activities/a\x00.json", r"control character"),
        ("activities", r"not inside the script root 'activities'"),
        ("activitiesX/a.json", r"not inside the script root"),
        ("other/a.json", r"not inside the script root"),
    ],
)
def test_bad_script_path_is_named(path, problem):
    found = check_script_path(path, script_root="activities")
    assert found is not None
    assert re.search(problem, found)


@pytest.mark.parametrize("path", ["activities/a.json", "activities/sub/b.txt", "activities/..a"])
def test_good_script_path_is_accepted(path):
    assert check_script_path(path, script_root="activities") is None


def test_empty_script_root_accepts_any_relative_path():
    assert check_script_path("x/y.json", script_root="") is None
    assert check_script_path("../y.json", script_root="") is not None


def test_script_root_itself_must_be_relative_and_normalised():
    assert check_script_root(".") == ""
    assert check_script_root("scenarios/library") == "scenarios/library"
    with pytest.raises(ValueError, match=r"script_root: path '/abs' is absolute"):
        check_script_root("/abs")


def test_script_vect_names_a_generated_script_by_its_activity():
    jsonmsg = '{"restart": "s_false", "update": ["activities/a.json", "generator:test_dance"]}'
    decoded = decode_update(upd("Script", "script_vect", jsonmsg))
    assert decoded.value == ScriptVect(
        restart=False, paths=("activities/a.json", "generator:test_dance")
    )


@pytest.mark.parametrize("name", ["", "a b", "a/b", "..\\x", "a\u0000"])
def test_script_vect_refuses_a_generated_script_with_a_bad_name(name):
    jsonmsg = msgspec.json.encode({"restart": "s_false", "update": [f"generator:{name}"]})
    with pytest.raises(MapUpdateError, match=r"at `\$\.update\[0\]`: 'generator:.*bad activity"):
        decode_update(upd("Script", "script_vect", jsonmsg.decode()))


def test_script_vect_with_a_custom_root():
    decoded = decode_update(
        upd("Script", "script_vect", '{"restart": "s_false", "update": ["lib/a.json"]}'),
        script_root="lib",
    )
    assert decoded.value == ScriptVect(restart=False, paths=("lib/a.json",))
    with pytest.raises(MapUpdateError, match="not inside the script root 'lib'"):
        decode_update(
            upd("Script", "script_vect", '{"restart": "s_false", "update": ["activities/a"]}'),
            script_root="lib",
        )


@pytest.mark.parametrize("letter", "chpst")
def test_a_lower_case_touch_type_is_its_upper_case_type(letter):
    """Thesis table 4.1: touch is {"touchtype": char, ...}: a char, whatever its case."""
    jsonmsg = f'{{"touchtype": "{letter}", "duration": 5, "startingtime": 1}}'
    decoded = decode_update(upd("RobotStatus", "touch", jsonmsg))
    assert decoded.value == Touch(touchtype=letter.upper(), duration=5, startingtime=1)


def test_a_touch_type_outside_the_five_letters_is_refused_in_either_case():
    """Thesis table 4.1: touch is {"touchtype": char, ...}; only C, H, P, S, T are known."""
    with pytest.raises(MapUpdateError, match="touchtype"):
        decode_update(
            upd("RobotStatus", "touch", '{"touchtype": "x", "duration": 5, "startingtime": 1}')
        )
