"""How simulated humans move: each behaviour segment turns into a velocity every tick.

A ``HumanDriver`` knows nothing of pymunk: given where the human and the robot are,
it returns the velocity (m/s, world frame) for the next tick. Its only randomness
is its own generator, seeded from the ``random.Random`` it is handed (the scenario's
seeded world stream) and drawn in a fixed order, so each seed gives a different but
reproducible person: a walking pace per segment (:data:`PACE`), pauses (``wander``
targets and pause lengths, :data:`PAUSE`), a starting heading, and, while standing,
where they look (glances towards the robot or elsewhere every :data:`GLANCE_S`).
"""

from __future__ import annotations

import math
import os
import random
import re
from collections.abc import Callable, Mapping, Sequence
from typing import Final, NamedTuple, Protocol

from oimi.pipeline.act.limits import capped
from oimi.pipeline.errors import FAILURES, failure
from oimi.pipeline.texts import clipped
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.schema import (
    Approach,
    BehaviourSegment,
    Custom,
    Follow,
    HumanSpec,
    Leave,
    Stand,
    Wander,
    Waypoints,
)

Point = tuple[float, float]

STILL: Final = (0.0, 0.0)
"""The velocity of a human who stands (one object, so the world sees at once it is unchanged)."""

PACE: Final = (0.85, 1.1)
"""A segment's speed is its nominal speed times a factor drawn from this range (then capped
at the human's ``max_speed_mps``): people do not walk at exactly the scripted speed."""
PAUSE: Final = (0.5, 1.5)
"""A ``wander`` pause lasts its ``pause_s`` times a factor drawn from this range."""
GLANCE_S: Final = (2.0, 6.0)
"""A standing human looks somewhere new after a time drawn from this range: towards the
robot half of the time, else up to 90 degrees away from it."""


class Arena(NamedTuple):
    """The room's size and exit, m."""

    width_m: float
    height_m: float
    exit_m: Point


class BehaviourView(NamedTuple):
    """What an extension's behaviour sees each tick (positions in m, world frame)."""

    position: Point
    robot: Point
    time_ms: int
    dt_s: float
    speed_mps: float
    """The segment's walking speed (capped by the human's maximum)."""
    arena: Arena
    rng: random.Random
    """The world's seeded generator: draw from it only, in a fixed order."""


class Behaviour(Protocol):
    """A human behaviour an extension adds: a velocity each tick."""

    def velocity(self, view: BehaviourView) -> tuple[float, float]:
        """World-frame velocity (m/s) for the tick starting at ``view.time_ms``."""
        ...


BehaviourFactory = Callable[[Mapping[str, float | str]], Behaviour]
"""Makes a behaviour from the segment's ``options`` (once per segment start)."""

BUILTIN_BEHAVIOURS: Final = (
    "approach",
    "custom",
    "follow",
    "leave",
    "stand",
    "wander",
    "waypoints",
)
"""Segment kinds of the schema; an extension's behaviour may not take one of these names."""

_hypot: Final = math.hypot
_atan2: Final = math.atan2
"""Looked up once: a walking human's velocity and heading use them at every tick."""

SHOWN: Final = 60
"""The most characters of a bad value a behaviour returned that its error quotes."""
_ADDRESS: Final = re.compile(r" at 0x[0-9a-fA-F]+")


def make_behaviour(
    segment: Custom, behaviours: Mapping[str, BehaviourFactory], human: str
) -> Behaviour:
    """The behaviour of ``human``'s ``custom`` segment, made by its extension's factory; a
    factory that raises, or makes no ``velocity``, is a :class:`ScenarioError`."""
    factory = behaviours[segment.name]
    try:
        behaviour = factory(dict(segment.options))
    except FAILURES as error:  # an extension's bug or a bad option: named, not a traceback
        raise _failed(human, segment.name, f"could not start: {_raised(error)}") from None
    if not callable(getattr(behaviour, "velocity", None)):
        kind = type(behaviour).__name__
        raise _failed(human, segment.name, f"made a {kind}, which has no velocity(view) method")
    return behaviour


class HumanDriver:
    """Follows one human's timeline of behaviour segments (and segments switched in by events)."""

    def __init__(
        self,
        spec: HumanSpec,
        *,
        arena: Arena,
        rng: random.Random,
        behaviours: Mapping[str, BehaviourFactory] | None = None,
        later: Sequence[BehaviourSegment] = (),
    ):
        """``later``: the segments behaviour events will switch in."""
        self.spec = spec
        self.behaviours = behaviours or {}
        """Extension behaviours by name, for ``custom`` segments."""
        self._custom: Behaviour | None = None
        self.arena = arena
        self.rng = random.Random(rng.getrandbits(64))
        """This human's own stream (drawn from the world's at construction, in scenario order)."""
        self.segment: BehaviourSegment = Stand()
        self.left = False
        """True once a ``leave`` segment reached the exit (until another segment starts)."""
        self.heading_rad = self.rng.uniform(-math.pi, math.pi)
        self._pace = self.rng.uniform(*PACE)
        self._glance_ms = 0
        self._timeline = list(spec.behaviour)
        self._made = {
            id(segment): make_behaviour(segment, self.behaviours, spec.id)
            for segment in (*self._timeline, *later)
            if isinstance(segment, Custom)
        }
        """The behaviours of the ``custom`` segments to come, by the segment's ``id``: made as
        the world is built, so that a factory that fails does so before the first tick."""
        self._starts_ms = [round(segment.at_s * 1000) for segment in self._timeline]
        """When each timeline segment starts, ms (worked out once, checked every tick)."""
        self._next = 0
        self._due_ms: float = self._starts_ms[0] if self._starts_ms else math.inf
        """When the next timeline segment starts (``inf``: none left)."""
        self._target: Point | None = None
        self._waypoint = 0
        self._pause_until_ms = 0
        self._done = False
        self._standing = True
        self._wandering = False
        self._leaving = False
        radius = spec.radius_m
        self._inner = (radius, arena.width_m - radius, arena.height_m - radius)
        """Where the disc's centre may go freely: ``(low, high_x, high_y)``."""
        self._speed = 0.0

    def _start_due(self, time_ms: int) -> None:
        """Start the timeline's segments due by ``time_ms``, in order."""
        while self._next < len(self._timeline) and self._starts_ms[self._next] <= time_ms:
            self.switch(self._timeline[self._next])
            self._next += 1
        self._due_ms = self._starts_ms[self._next] if self._next < len(self._timeline) else math.inf

    def switch(self, segment: BehaviourSegment) -> None:
        """Start ``segment`` now (a behaviour event); the human comes back if it had left."""
        self.segment = segment
        self.left = False
        self._pace = self.rng.uniform(*PACE)
        self._target = None
        self._waypoint = 0
        self._pause_until_ms = 0
        self._done = False
        self._custom = None
        self._standing = isinstance(segment, Stand)
        self._wandering = isinstance(segment, Wander)
        self._leaving = isinstance(segment, Leave)
        self._speed = self._speed_of(segment)
        if isinstance(segment, Custom):
            made = self._made.pop(id(segment), None)
            self._custom = (
                made if made is not None else make_behaviour(segment, self.behaviours, self.spec.id)
            )

    def velocity(
        self, position: Point, robot: Point, time_ms: int, dt_s: float
    ) -> tuple[float, float]:
        """World-frame velocity (m/s) for the tick starting at ``time_ms``."""
        if time_ms >= self._due_ms:
            self._start_due(time_ms)
        if self.left:
            return STILL
        segment = self.segment
        if self._standing:  # the fast path: nothing to work out but a glance now and then
            if time_ms >= self._glance_ms:
                self._glance(position, robot, time_ms)
            return STILL
        speed = self._speed
        vx, vy = 0.0, 0.0
        if self._wandering:  # the most common walk, tested first
            if time_ms < self._pause_until_ms:
                return STILL
            vx, vy = self._wander(position, time_ms, speed, dt_s, segment)
        else:
            vx, vy = self._walk(segment, position, robot, time_ms, speed, dt_s)
        if (vx or vy) and not self._leaving:  # standing still stays inside
            vx, vy = self._inside(position, vx, vy, dt_s)
        if vx or vy:
            self.heading_rad = _atan2(vy, vx)
        return (vx, vy)

    def _speed_of(self, segment: BehaviourSegment) -> float:
        """The segment's walking speed: its own (or the human's top speed) times the pace."""
        speed = segment.speed_mps if segment.speed_mps is not None else self.spec.max_speed_mps
        speed = min(speed * self._pace, self.spec.max_speed_mps)
        if not (math.isfinite(speed) and speed > 0):  # refused by the loader; never NaN here
            speed = 0.0
        return speed

    def _walk(
        self,
        segment: BehaviourSegment,
        position: Point,
        robot: Point,
        time_ms: int,
        speed: float,
        dt_s: float,
    ) -> tuple[float, float]:
        """The velocity of the segments other than ``stand`` and ``wander``."""
        vx, vy = 0.0, 0.0
        match segment:
            case Waypoints(waypoints=points, loop=loop):
                if self._waypoint < len(points):
                    vx, vy, arrived = _towards(position, points[self._waypoint], speed, dt_s)
                    if arrived:
                        self._waypoint += 1
                        if loop and self._waypoint == len(points):
                            self._waypoint = 0
            case Approach(distance_m=distance):
                if not self._done:
                    vx, vy, self._done = _keep_distance(position, robot, distance, speed, dt_s)
            case Follow(distance_m=distance):
                vx, vy, _ = _keep_distance(position, robot, distance, speed, dt_s)
            case Custom(name=name):
                assert self._custom is not None  # made by switch
                view = BehaviourView(position, robot, time_ms, dt_s, speed, self.arena, self.rng)
                vx, vy = self._custom_velocity(self._custom, name, view)
            case Leave():
                vx, vy, arrived = _towards(position, self.arena.exit_m, speed, dt_s)
                if arrived:
                    self.left = True
        return (vx, vy)

    def _custom_velocity(
        self, custom: Behaviour, name: str, view: BehaviourView
    ) -> tuple[float, float]:
        """The velocity of the extension behaviour ``name``, capped at the human's
        ``max_speed_mps`` (what the safety supervisor assumes they walk at, at most); one that
        raises, or returns anything but two finite numbers, is a :class:`ScenarioError` (the
        run stops there)."""
        try:
            velocity = custom.velocity(view)
        except FAILURES as error:
            raise _failed(self.spec.id, name, f"raised {_raised(error)}") from None
        try:
            vx, vy = velocity
            if math.isfinite(vx) and math.isfinite(vy):
                return capped(vx, vy, self.spec.max_speed_mps)
        except (TypeError, ValueError):  # not two numbers
            pass
        problem = f"returned {_shown(velocity)}, not a velocity pair (vx, vy) of finite numbers"
        raise _failed(self.spec.id, name, problem + _defined_at(custom.velocity))

    def _wander(
        self, position: Point, time_ms: int, speed: float, dt_s: float, segment: Wander
    ) -> tuple[float, float]:
        """Towards a random target, then a pause (the caller skips the pause's ticks)."""
        if self._target is None:
            margin = max(segment.margin_m, self.spec.radius_m)
            width, height = self.arena.width_m, self.arena.height_m
            x = self.rng.uniform(min(margin, width / 2), max(width - margin, width / 2))
            y = self.rng.uniform(min(margin, height / 2), max(height - margin, height / 2))
            self._target = (x, y)
        vx, vy, arrived = _towards(position, self._target, speed, dt_s)
        if arrived:
            self._target = None
            pause_s = segment.pause_s * self.rng.uniform(*PAUSE)
            self._pause_until_ms = time_ms + round(pause_s * 1000)
        return (vx, vy)

    def _glance(self, position: Point, robot: Point, time_ms: int) -> None:
        """A standing human's attention, when a glance is due: a look at the robot or away."""
        self._glance_ms = time_ms + round(self.rng.uniform(*GLANCE_S) * 1000)
        towards = _atan2(robot[1] - position[1], robot[0] - position[0])
        away = 0.0 if self.rng.random() < 0.5 else self.rng.uniform(-math.pi / 2, math.pi / 2)
        self.heading_rad = math.remainder(towards + away, math.tau)

    def _inside(self, position: Point, vx: float, vy: float, dt_s: float) -> tuple[float, float]:
        """The velocity, cut so the human's disc does not move further out of the arena."""
        px, py = position
        x, y = px + vx * dt_s, py + vy * dt_s
        low, high_x, high_y = self._inner
        if low <= x <= high_x and low <= y <= high_y:  # well inside: the clamp below is a no-op
            return (vx, vy)
        radius = self.spec.radius_m
        cx = min(max(x, min(radius, px)), max(self.arena.width_m - radius, px))
        cy = min(max(y, min(radius, py)), max(self.arena.height_m - radius, py))
        if (cx, cy) == (x, y):
            return (vx, vy)
        return ((cx - px) / dt_s, (cy - py) / dt_s)


def _failed(human: str, name: str, problem: str) -> ScenarioError:
    """``human``'s behaviour ``name`` went wrong: bad input, so the command exits 2."""
    return ScenarioError(f"behaviour {name!r} {problem}", source=f"human {human!r}")


def _raised(error: BaseException) -> str:
    """What a behaviour raised, placed in its own code (the frame here is left out)."""
    frames = error.__traceback__
    return failure(error.with_traceback(frames.tb_next if frames is not None else None))


def _shown(value: object) -> str:
    """``value`` for a message: without memory addresses, cut to :data:`SHOWN` characters."""
    return clipped(_ADDRESS.sub("", repr(value)), SHOWN)


def _defined_at(method: object) -> str:
    """`` (FILE:LINE)`` where ``method`` is defined (by the file's name only), or ``""``."""
    code = getattr(method, "__code__", None)
    return f" ({os.path.basename(code.co_filename)}:{code.co_firstlineno})" if code else ""


def _towards(
    position: Point, target: Point, speed: float, dt_s: float
) -> tuple[float, float, bool]:
    """Velocity towards ``target`` at ``speed``, landing on it exactly; and whether it lands."""
    dx, dy = target[0] - position[0], target[1] - position[1]
    distance = _hypot(dx, dy)
    if distance <= speed * dt_s:
        return (dx / dt_s, dy / dt_s, True)
    return (dx / distance * speed, dy / distance * speed, False)


def _keep_distance(
    position: Point, robot: Point, distance_m: float, speed: float, dt_s: float
) -> tuple[float, float, bool]:
    """Velocity towards the robot until ``distance_m`` from it (centre to centre); and if there."""
    dx, dy = robot[0] - position[0], robot[1] - position[1]
    gap = _hypot(dx, dy) - distance_m
    if gap <= 1e-9:
        return (0.0, 0.0, True)
    step = min(speed, gap / dt_s)
    norm = _hypot(dx, dy)
    return (dx / norm * step, dy / norm * step, step < speed)
