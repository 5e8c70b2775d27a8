"""What a session with a real robot (``oimi bridge``, ``oimi replay BAG/``) asks of a scenario.

A scenario written for the simulation may leave out what the simulated sensors make
plain and a lab's do not: the camera's view and range, whether the ring's echoes are
surfaces, how long the sensors may miss a child. Refusals where the robot would count on
more than a real child allows (:func:`check_real_people`), overrides and warnings where it
only costs stops (:func:`real_robot_overrides`, :func:`real_robot_warnings`); each placed
at its line of the scenario's file.
"""

from __future__ import annotations

import tomllib
from typing import Any, Final

from oimi.pipeline.act.safety_config import ASSUMED
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.loader import Invalid, LoadedScenario, TomlLocator, first_of, located
from oimi.scenarios.safety import unknown_people


def check_real_people(loaded: LoadedScenario) -> None:
    """Refuse (``ScenarioError``, placed in the file) a scenario that assumes less of people
    than the safety supervisor does, or an ideal sonar ring, for a session with a real
    robot and real people (:func:`real_people_problems`)."""
    errors = real_people_problems(loaded)
    if errors:
        raise first_of(list(errors))


def real_people_problems(loaded: LoadedScenario) -> tuple[ScenarioError, ...]:
    """What the scenario gets wrong of a real robot's people and sonar ring
    (``scenarios.safety.unknown_people``), placed in the file, in its order: refusals for
    ``oimi bridge``, warnings for a rosbag2 driven through it (a bag's readings are real)."""
    problems = list(unknown_people(loaded.scenario))
    if (
        "fov_rad" not in _sensors_written(loaded)
        and loaded.scenario.robot.safety.camera_fov_rad is None
    ):
        problems.append((("sensors", "fov_rad"), UNSET_VIEW))
    return _placed(loaded, problems)


UNSET_VIEW: Final = (
    "not set: give the robot's camera's horizontal field of view (the simulated camera's"
    " 2.2 rad may be wider than the lab's: while a sonar is down the robot drives only"
    " inside that view, narrowed for a child at its edge)"
)
"""Why a session with a real robot needs ``[sensors] fov_rad`` (or ``[robot.safety]
camera_fov_rad``) set."""


REAL_RANGE: Final = {"robot.safety.camera_range_m": repr(ASSUMED["camera_range_m"])}
"""What a session with a real robot changes of a scenario that states no camera range
(:func:`real_robot_overrides`)."""
REAL_SURFACE: Final = {"robot.safety.sonar_reports_surface": "false"}
"""What a session with a real robot changes of a scenario that does not say whether its
ring's echoes are surfaces (the simulated merging ring's are: :func:`real_robot_overrides`)."""


def real_robot_overrides(loaded: LoadedScenario) -> dict[str, str]:
    """The overrides a session with a real robot (``oimi bridge``, ``oimi replay BAG/``)
    applies to the scenario, recorded as its ``variation`` (a redrive rebuilds the same
    supervisor): :data:`REAL_RANGE` when the scenario states neither ``[sensors] range_m``
    nor ``[robot.safety] camera_range_m`` (the simulated camera's 5 m may reach farther than
    the lab's tracker, and a child beyond its range is never reported: a shorter range only
    keeps more echoes); :data:`REAL_SURFACE` when it leaves ``[robot.safety]
    sonar_reports_surface`` out (the simulated merging ring reports surfaces; a lab driver
    that reports a body's centre, taken for a surface, would have its echo kept a radius
    too far: false covers either). Not refusals, unlike the view (:data:`UNSET_VIEW`): they
    cost stops, not safety (:func:`real_robot_warnings` says so)."""
    overrides = dict(REAL_RANGE) if _range_unstated(loaded) else {}
    if loaded.scenario.robot.safety.sonar_reports_surface is None:
        overrides |= REAL_SURFACE
    return overrides


def real_robot_warnings(loaded: LoadedScenario) -> tuple[ScenarioError, ...]:
    """What a session with a real robot assumes that the scenario leaves unstated (its
    camera's range and its ring's kind of echo, :func:`real_robot_overrides`; that its
    sensors never miss a child, :data:`UNSET_MISSES`), placed in the file, in its order."""
    problems = [(("sensors", "range_m"), UNSET_RANGE)] if _range_unstated(loaded) else []
    safety = loaded.scenario.robot.safety
    if safety.sonar_reports_surface is None:
        problems.append((("robot", "safety", "sonar_reports_surface"), UNSET_SURFACE))
    if not loaded.scenario.sensors.dropout_probability:  # (else its misses are derived)
        problems += [
            (("robot", "safety", name), why)
            for name, why in UNSET_MISSES.items()
            if getattr(safety, name) is None
        ]
    return _placed(loaded, problems)


UNSET_RANGE: Final = (
    f"not set: the safety supervisor takes the robot's camera to report people within"
    f" {ASSUMED['camera_range_m']!r} m (the simulated camera's 5.0 m may reach farther than"
    " the lab's): give the lab camera's range (or [robot.safety] camera_range_m), or an"
    " echo of a child it tracks farther away is kept as a body of its own (more stops)"
)
"""Why a session with a real robot warns of an unstated ``[sensors] range_m``."""
UNSET_SURFACE: Final = (
    "not set: the safety supervisor takes each echo's range for one that may be a body's"
    " centre (false: the echo's centre kept at its range, a child's radius counted twice"
    " near the robot: more stops); where the lab's sonar driver passes the raw sonar range"
    " (the nearest surface heard), state true (with [sensors] sonar_beams its sonars);"
    " where it reports centres, state false"
)
"""Why a session with a real robot warns of an unstated ``[robot.safety]
sonar_reports_surface``."""
UNSET_MISSES: Final = {
    "camera_miss_ms": "not set: the safety supervisor takes the lab's person tracker to report"
    " every child in its view on every frame (0 ms); where it may miss one on frames in a row,"
    " state how long (with a sonar down the robot would count on seeing a child ahead sooner"
    " than it can)",
    "sonar_miss_ms": "not set: the safety supervisor takes the lab's sonar ring to report every"
    " body on every scan (0 ms); where it may miss one on scans in a row, state how long (a"
    " ring back from down would be taken to see beside and behind the robot before it can)",
}
"""Why a session with a real robot warns of an unstated ``[robot.safety] camera_miss_ms``
or ``sonar_miss_ms`` (a scenario whose ``[sensors] dropout_probability`` is 0)."""


def _range_unstated(loaded: LoadedScenario) -> bool:
    """Whether the scenario states neither its camera's range nor the supervisor's."""
    return (
        "range_m" not in _sensors_written(loaded)
        and loaded.scenario.robot.safety.camera_range_m is None
    )


def _sensors_written(loaded: LoadedScenario) -> dict[str, Any]:
    """The keys the scenario's file writes in ``[sensors]`` (not the schema's defaults:
    a real robot's camera is not the simulated one)."""
    sensors = tomllib.loads(loaded.raw.decode("utf-8")).get("sensors", {})
    return sensors if isinstance(sensors, dict) else {}


def _placed(
    loaded: LoadedScenario, problems: list[tuple[tuple[str, ...], str]]
) -> tuple[ScenarioError, ...]:
    """``problems`` (field path, what is wrong) placed in the scenario's file, in its order."""
    locator = TomlLocator(loaded.raw.decode("utf-8"))
    errors = [
        located(Invalid(where, what), str(loaded.source), locator) for where, what in problems
    ]
    return tuple(sorted(errors, key=lambda error: (error.line or 0, error.column or 0)))
