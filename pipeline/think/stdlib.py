"""The standard functions of the rule language (families B, F and E).

Each docstring ends with an ``Example:`` line holding a condition that compiles
(a test checks them). Distances in metres, angles in radians, times in ms of the
simulated clock.
"""

from __future__ import annotations

import functools
import sys
from typing import Final

from oimi.pipeline.messages import ENTITY_LISTS, ActivityTracking, Entity, GoalTracking, Object
from oimi.pipeline.think.functions import (
    TIME,
    Bound,
    FunctionContext,
    FunctionRegistry,
    boolean,
    evaluation,
    string,
)

FRONT_ANGLE_RAD: Final = 0.5
"""Default half-width of "in front of the robot", rad."""

ATTENTION_WINDOW_MS: Final = 3000
"""Default window of ``attention_low``, ms."""

TOUCH_WINDOW_MS: Final = 1000
"""Default window of ``touched``, ms."""

SPATIAL: Final = tuple(m.name for m in ENTITY_LISTS)

_KNOWN: Final = ("robotstatus.setfields",)
"""What ``RobotStatus.known`` reads (declared by the functions that call it)."""


def _number_text(value: float) -> str:
    """A number as an F function returns it: integers without ``.0``."""
    return str(int(value)) if float(value).is_integer() else repr(float(value))


def _in_front(theta_rad: float, max_angle_rad: float) -> bool:
    return abs(theta_rad) <= max_angle_rad


# ------------------------------------------------------------------------ family B


@boolean("infront", classes=SPATIAL, reads=())
def infront(ctx: FunctionContext, entity: Entity, max_angle_rad: float = FRONT_ANGLE_RAD) -> bool:
    """The entity's bearing is within ``max_angle_rad`` of the robot's heading.

    Example: {CLASS #Human U ?child B: infront (0.3)} ! {TRUE}
    """
    return _in_front(entity.positiontheta, max_angle_rad)


@boolean("closer_than", classes=SPATIAL, reads=())
def closer_than(ctx: FunctionContext, entity: Entity, distance_m: float) -> bool:
    """The entity is nearer than ``distance_m`` to the robot.

    Example: {CLASS #Obstacle L ?wall B: closer_than (0.4)} ! {TRUE}
    """
    return entity.positionrho < distance_m


@boolean("farther_than", classes=SPATIAL, reads=())
def farther_than(ctx: FunctionContext, entity: Entity, distance_m: float) -> bool:
    """The entity is farther than ``distance_m`` from the robot.

    Example: {CLASS #Human T ?far B: farther_than (2)} ! {TRUE}
    """
    return entity.positionrho > distance_m


@boolean("has_attribute", classes=SPATIAL, reads=())
def has_attribute(ctx: FunctionContext, entity: Entity, name: str) -> bool:
    """The entity carries the free attribute ``name`` (set by sensors or generators).

    Example: {CLASS #Human U ?child B: has_attribute ("name")} ! {TRUE}
    """
    return name in entity.attributes


@boolean("attribute_is", classes=SPATIAL, reads=())
def attribute_is(ctx: FunctionContext, entity: Entity, name: str, value: str) -> bool:
    """The entity's free attribute ``name`` equals ``value``.

    Example: {CLASS #Human U ?child B: attribute_is ("role", "child")} ! {TRUE}
    """
    return entity.attributes.get(name) == value


@boolean("seen_within", classes=SPATIAL, reads=(TIME,))
def seen_within(ctx: FunctionContext, entity: Entity, window_ms: float) -> bool:
    """The entity's position was updated in the last ``window_ms``.

    Example: {CLASS #Human L ?h B: seen_within (500)} ! {TRUE}
    """
    return ctx.now_ms - entity.positionchangetime <= window_ms


@boolean("tracked_for", classes=SPATIAL, reads=())
def tracked_for(ctx: FunctionContext, entity: Entity, duration_ms: float) -> bool:
    """The entity has been tracked (``permanencetime``) for at least ``duration_ms``.

    Example: {CLASS #Human U ?child B: tracked_for (2000)} ! {TRUE}
    """
    return entity.permanencetime >= duration_ms


@boolean("is_target", classes=("Object",), reads=())
def is_target(ctx: FunctionContext, entity: Bound) -> bool:
    """The object is a target of the activity (``istarget``).

    Example: {CLASS #Object U ?ball B: is_target ()} ! {E: near (?ball, 0.5)}
    """
    return isinstance(entity, Object) and entity.istarget


@boolean("activity_is", classes=("Activity",), reads=())
def activity_is(ctx: FunctionContext, entity: Bound, status: str) -> bool:
    """The activity's status is ``status`` (``loaded``, ``running``, ``completed``...).

    Example: {CLASS #Activity L ?act B: activity_is ("running")} ! {TRUE}
    """
    return isinstance(entity, ActivityTracking) and entity.status == status


# ------------------------------------------------------------------------ family F


@string("attribute", reads=())
def attribute(ctx: FunctionContext, entity: Entity, name: str) -> str | None:
    """The entity's free attribute ``name`` (the assignment fails when it has none).

    Example: {CLASS #Human U ?child}, {VAR @name L F: attribute (?child, "name")} ! {TRUE}
    """
    return entity.attributes.get(name)


@string("distance", reads=())
def distance(ctx: FunctionContext, entity: Entity) -> str:
    """The entity's distance from the robot, m, as text.

    Example: {CLASS #Human U ?child}, {ATT ?child $dist L F: distance (?child)} ! {TRUE}
    """
    return _number_text(entity.positionrho)


@string("bearing", reads=())
def bearing(ctx: FunctionContext, entity: Entity) -> str:
    """The entity's bearing from the robot's heading, rad, as text.

    Example: {CLASS #Human U ?child}, {VAR @b T F: bearing (?child)} ! {TRUE}
    """
    return _number_text(entity.positiontheta)


@string("concat", reads=())
def concat(ctx: FunctionContext, first: str, *rest: str) -> str:
    """The texts joined together.

    Example: {VAR @greeting L F: concat ("hello ", "world")} ! {TRUE}
    """
    return first + "".join(rest)


@string("now", reads=(TIME,))
def now(ctx: FunctionContext) -> str:
    """The simulated time of the evaluation, ms, as text.

    Example: {VAR @started U F: now ()} ! {TRUE}
    """
    return str(ctx.now_ms)


@string("current_activity", reads=("scriptinfo.currentactivity",))
def current_activity(ctx: FunctionContext) -> str:
    """The name of the running activity (``scriptinfo.currentactivity``).

    Example: {VAR @act L F: current_activity ()} ! {E: var_is (@act, "idle_activity")}
    """
    return ctx.world_map.scriptinfo.currentactivity


# ------------------------------------------------------------------------ family E


@evaluation("near", reads=())
def near(ctx: FunctionContext, entity: Entity, distance_m: float) -> bool:
    """The entity is nearer than ``distance_m`` (child too close).

    Example: {CLASS #Human U ?child} ! {E: near (?child, 0.5)}
    """
    return entity.positionrho < distance_m


@evaluation("far", reads=())
def far(ctx: FunctionContext, entity: Entity, distance_m: float) -> bool:
    """The entity is farther than ``distance_m`` (child leaving the area).

    Example: {CLASS #Human U ?child} ! {E: far (?child, 3)}
    """
    return entity.positionrho > distance_m


@evaluation("lost", reads=())
def lost(ctx: FunctionContext, entity: Bound | None) -> bool:
    """The alias is unbound or its entity has left the map (child left the area).

    Example: ! {E: lost (?child)}
    """
    return entity is None


@evaluation("attention_low", reads=(TIME,))
def attention_low(
    ctx: FunctionContext, entity: Entity, window_ms: float = ATTENTION_WINDOW_MS
) -> bool:
    """The entity has not been in front of the robot at any observation of the last ``window_ms``.

    Observations are the current pose and the ``poses`` register; "in front" is
    within ``FRONT_ANGLE_RAD``. False while the entity is known for less than the window.

    Example: {CLASS #Human U ?child} ! {E: attention_low (?child, 5000)}
    """
    since_ms = ctx.now_ms - window_ms
    if entity.creationtime > since_ms:
        return False
    if entity.positionchangetime >= since_ms and _in_front(entity.positiontheta, FRONT_ANGLE_RAD):
        return False
    for pose in entity.poses:  # a plain loop: it runs on every pass of attention_lost
        if pose.positionchangetime >= since_ms and _in_front(pose.positiontheta, FRONT_ANGLE_RAD):
            return False
    return True


@evaluation("touched", reads=("robotstatus.touch", TIME))
def touched(ctx: FunctionContext, touchtype: str, window_ms: float = TOUCH_WINDOW_MS) -> bool:
    """A touch of type ``touchtype`` (C, H, P, S, T; either case) started in the last
    ``window_ms``.

    Example: ! {E: touched ("C", 2000)}
    """
    since_ms = ctx.now_ms - window_ms
    wanted = touchtype.upper()
    for t in ctx.world_map.robotstatus.touch:  # (a plain loop: any() over a generator costs more)
        if t.touchtype == wanted and t.startingtime >= since_ms:
            return True
    return False


@evaluation("no_human_in_front", reads=("humans",))
def no_human_in_front(ctx: FunctionContext, max_angle_rad: float = FRONT_ANGLE_RAD) -> bool:
    """No human of the map is within ``max_angle_rad`` of the robot's heading.

    Example: ! {E: no_human_in_front ()}
    """
    return not any(_in_front(h.positiontheta, max_angle_rad) for h in ctx.world_map.humans)


@evaluation("battery_below", reads=(*_KNOWN, "robotstatus.batterytimeleft"))
def battery_below(ctx: FunctionContext, time_left_ms: float) -> bool:
    """The battery has less than ``time_left_ms`` left (false before any battery reading).

    Example: ! {E: battery_below (600000)}
    """
    status = ctx.world_map.robotstatus
    return status.known("batterytimeleft") and status.batterytimeleft < time_left_ms


def _goal(ctx: FunctionContext, goalid: str) -> GoalTracking | None:
    activities = ctx.world_map.robotstatus.activities
    current = ctx.world_map.scriptinfo.currentactivity
    ordered = [a for a in activities if a.activityname == current]
    ordered += [a for a in activities if a.activityname != current]
    for activity in ordered:
        for goal in activity.goals:
            if goal.goalid == goalid:
                return goal
    return None


@evaluation("goal_is", reads=("robotstatus.activities", "scriptinfo.currentactivity"))
def goal_is(ctx: FunctionContext, goalid: str, status: str) -> bool:
    """The goal ``goalid`` (of the running activity first, then any) has ``status``.

    Example: ! {E: goal_is ("greet", "reached")}
    """
    goal = _goal(ctx, goalid)
    return goal is not None and goal.status == status


@evaluation("elapsed_over", reads=(*_KNOWN, "robotstatus.elapsedtime"))
def elapsed_over(ctx: FunctionContext, elapsed_ms: float) -> bool:
    """More than ``elapsed_ms`` have passed since the session started (false while no
    ``elapsedtime`` was reported).

    Example: ! {E: elapsed_over (60000)}
    """
    status = ctx.world_map.robotstatus
    return status.known("elapsedtime") and status.elapsedtime > elapsed_ms


@evaluation("var_is", reads=())
def var_is(ctx: FunctionContext, value: str, expected: str) -> bool:
    """A variable's value (``@v``) equals ``expected`` (false when ``@v`` is unbound).

    Example: {VAR @mood U F: concat ("happy")} ! {E: var_is (@mood, "happy")}
    """
    return value == expected


@evaluation("joystick_engaged", reads=("robotstatus.joystick_engaged",))
def joystick_engaged(ctx: FunctionContext) -> bool:
    """The operator holds the joystick's safety lock.

    Example: ! {E: joystick_engaged ()}
    """
    return ctx.world_map.robotstatus.joystick_engaged


def _same(a: object, b: object) -> bool:
    try:
        return float(a) == float(b)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return str(a) == str(b)


@evaluation("equals", reads=())
def equals(ctx: FunctionContext, a: object, b: object) -> bool:
    """``a`` equals ``b``: numerically when both read as numbers, else as texts.

    Example: {CLASS #Human U ?child} ! {E: equals (?child>$mood, "calm")}
    """
    return _same(a, b)


@evaluation("differs", reads=())
def differs(ctx: FunctionContext, a: object, b: object) -> bool:
    """The negation of ``equals``.

    Example: {VAR @act L F: current_activity ()} ! {E: differs (@act, "idle_activity")}
    """
    return not _same(a, b)


@evaluation("less_than", reads=())
def less_than(ctx: FunctionContext, a: float, b: float) -> bool:
    """``a < b`` as numbers (false when either is not a number).

    Example: {CLASS #Human U ?child} ! {E: less_than (?child>&positionrho, 1.2)}
    """
    return a < b


@evaluation("greater_than", reads=())
def greater_than(ctx: FunctionContext, a: float, b: float) -> bool:
    """``a > b`` as numbers (false when either is not a number).

    Example: {VAR @t L F: now ()} ! {E: greater_than (@t, 10000)}
    """
    return a > b


@evaluation("camera_offline", reads=("cameras",))
def camera_offline(ctx: FunctionContext) -> bool:
    """A camera of the robot reports ``isonline`` false (its readings stopped).

    Example: ! {E: camera_offline ()}
    """
    return any(not camera.isonline for camera in ctx.world_map.cameras)


@functools.cache
def default_registry() -> FunctionRegistry:
    """The functions of this module as a registry (immutable, built once)."""
    return FunctionRegistry.from_module(sys.modules[__name__])
