"""The simulated therapy room: a pymunk space stepped at the scenario's fixed tick.

Top view, x right, y up, metres, no gravity. Walls and furniture are static;
objects (a ball) are dynamic discs that roll and stop; humans are kinematic discs
moved by their behaviours (they push the ball and the robot, nothing pushes them);
the robot is a dynamic disc whose velocity is set every step from the actuator's
body-frame command, within its speed and acceleration limits, like the thesis's
zero-friction omni-directional base (section 5.2): no drift, no sliding after a stop.
A braking command (``ActuatorOutputs.brake``: a protective stop) is braked to at
``max_accel_mps2``, as every change is: no base stops at once, and the safety supervisor
plans for that rate.
Walls and furniture stop it physically; a push never leaves it faster than its
speed limits (the drive re-clamps after every step).

Determinism: single-threaded space, fixed step, bodies created in the file's
order, randomness only from the ``random.Random`` handed in.
"""

from __future__ import annotations

import math
import random
from collections.abc import Mapping
from typing import Final

import msgspec
import pymunk
from oimi.pipeline.act.limits import capped
from oimi.pipeline.events import WorldState
from oimi.pipeline.messages import ActuatorOutputs
from oimi.scenarios.schema import BehaviourEvent, HumanSpec, ObjectSpec, Scenario
from oimi.scenarios.simulation.bodies import (
    BodyReader,
    Human,
    Motion,
    Robot,
    Thing,
    rigid_state,
    thing_state,
    wrap_angle,
)
from oimi.scenarios.simulation.humans import Arena, BehaviourFactory, HumanDriver
from pymunk._chipmunk import lib as _chipmunk

WALL_THICKNESS_M: Final = 0.1
CONTACT_TOLERANCE_M: Final = 0.02
"""Centre distance beyond the sum of radii still counted as a contact (solver slop)."""
STOP_SPEED_MPS: Final = 1e-3
"""A rolling object slower than this stops."""
_step_space: Final = _chipmunk.cpSpaceStep
"""Chipmunk's step, looked up once (a lookup on cffi's ``lib`` is a call of its own)."""


def stream_rng(seed: int, stream: str) -> random.Random:
    """An independent generator for one consumer (``"world"``, ``"sensors"``...) of a seed."""
    return random.Random(f"{seed}:{stream}")


class ContactSpan(msgspec.Struct, frozen=True, kw_only=True):
    """A human's contact with the robot, reported when it ends."""

    human: str
    touchtype: str
    startingtime_ms: int
    duration_ms: int


class StepReport(msgspec.Struct, frozen=True, kw_only=True):
    """What happened during one step (safety events)."""

    tick: int
    time_ms: int
    contacts: tuple[str, ...] = ()
    """Humans touching the robot after the step, in the scenario's order."""
    ended: tuple[ContactSpan, ...] = ()
    """Contacts that ended during the step."""
    left: tuple[str, ...] = ()
    """Humans who left the room during the step."""


class World:
    """The room, the robot, the humans and the objects; stepped one tick at a time."""

    def __init__(
        self,
        scenario: Scenario,
        rng: random.Random,
        *,
        behaviours: Mapping[str, BehaviourFactory] | None = None,
    ):
        """``behaviours``: the extensions' human behaviours, for ``custom`` segments."""
        self.scenario = scenario
        self.behaviours = behaviours or {}
        self.rng = rng
        self.tick_ms = scenario.tick_ms
        self.step_s = self.tick_ms / 1000
        spec = scenario.world
        self.arena = Arena(spec.width_m, spec.height_m, spec.exit_point)
        self.space = pymunk.Space()
        self.space.threads = 1
        self.space.gravity = (0.0, 0.0)
        self.space.damping = 1.0
        self.space.iterations = 20
        self.space.collision_slop = 0.001
        self.led: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self.audio = ""
        self.last_report = StepReport(tick=-1, time_ms=0)
        self.odometer = (0.0, 0.0, 0.0)
        """How far the robot went since the start, in its own frame after each step (m
        forward, m left, rad turned): what its wheels' odometry measures."""
        self._contact_start_ms: dict[str, int] = {}
        self._add_walls()
        self._add_obstacles()
        self.things = [self._add_thing(thing) for thing in spec.objects]
        self.humans = [self._add_human(human) for human in scenario.humans]
        self.robot = self._add_robot()
        self._robot = Robot(self.robot)
        robot = scenario.robot
        self._limits = (
            robot.max_speed_mps,
            robot.max_angular_speed_radps,
            robot.max_accel_mps2 * self.step_s,
            robot.max_angular_accel_radps2 * self.step_s,
        )
        """The drive's top speed and spin, and their changes per step."""
        self._reader = BodyReader(self.space, (self._robot, *self.humans, *self.things))
        self._direct_step = all(
            hasattr(self.space, name) for name in ("_bodies_to_check", "_removed_shapes")
        )
        """Whether this pymunk keeps what ``Space.step`` tidies where the world can see it."""

    @property
    def robot_motion(self) -> Motion:
        """The robot's position, angle, velocity and spin after the last step."""
        return self._robot.motion

    # ------------------------------------------------------------ building

    def _add_walls(self) -> None:
        width, height, half = self.arena.width_m, self.arena.height_m, WALL_THICKNESS_M / 2
        corners = [(-half, -half), (width + half, -half), (width + half, height + half)]
        corners.append((-half, height + half))
        body = self.space.static_body
        for start, end in zip(corners, corners[1:] + corners[:1], strict=True):
            wall = pymunk.Segment(body, start, end, half)
            wall.friction, wall.elasticity = 0.5, 0.6
            self.space.add(wall)

    def _add_obstacles(self) -> None:
        for obstacle in self.scenario.world.obstacles:
            body = pymunk.Body(body_type=pymunk.Body.STATIC)
            body.position = (obstacle.x_m, obstacle.y_m)
            body.angle = obstacle.angle_rad
            if obstacle.radius_m > 0:
                shape: pymunk.Shape = pymunk.Circle(body, obstacle.radius_m)
            else:
                shape = pymunk.Poly.create_box(body, (obstacle.width_m, obstacle.height_m))
            shape.friction, shape.elasticity = 0.5, 0.4
            self.space.add(body, shape)

    def _add_thing(self, spec: ObjectSpec) -> Thing:
        moment = pymunk.moment_for_circle(spec.mass_kg, 0, spec.radius_m)
        body = pymunk.Body(spec.mass_kg, moment)
        body.position = (spec.x_m, spec.y_m)
        shape = pymunk.Circle(body, spec.radius_m)
        shape.friction, shape.elasticity = 0.3, 0.7
        self.space.add(body, shape)
        return Thing(spec, body, self.step_s)

    def _add_human(self, spec: HumanSpec) -> Human:
        body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        body.position = (spec.x_m, spec.y_m)
        shape = pymunk.Circle(body, spec.radius_m)
        shape.friction, shape.elasticity = 0.5, 0.3
        self.space.add(body, shape)
        later = [
            event.segment
            for event in self.scenario.events
            if isinstance(event, BehaviourEvent) and event.human == spec.id
        ]
        driver = HumanDriver(
            spec, arena=self.arena, rng=self.rng, behaviours=self.behaviours, later=later
        )
        return Human(spec, driver, body, shape)

    def _add_robot(self) -> pymunk.Body:
        spec = self.scenario.robot
        body = pymunk.Body(spec.mass_kg, math.inf)  # infinite moment: contacts never spin it
        body.position = (
            spec.x_m if spec.x_m is not None else self.arena.width_m / 2,
            spec.y_m if spec.y_m is not None else self.arena.height_m / 2,
        )
        body.angle = spec.theta_rad
        shape = pymunk.Circle(body, spec.radius_m)
        shape.friction, shape.elasticity = 0.0, 0.0  # zero-friction Swedish wheels
        self.space.add(body, shape)
        return body

    # ------------------------------------------------------------- stepping

    def step(self, outputs: ActuatorOutputs, *, tick: int) -> StepReport:
        """Advance one tick (``tick * tick_ms`` to the next) with the actuator's outputs."""
        time_ms = tick * self.tick_ms
        robot_xy, before = self._robot.xy, self._robot.motion
        step_s = self.step_s
        for human in self.humans:
            if human.steer(robot_xy, time_ms, step_s):  # back in the room
                self.space.add(human.body, human.shape)
                self._reader.moved_bodies()
        self._drive_robot(outputs)
        self.led, self.audio = outputs.led, outputs.audio
        space = self.space
        if self._direct_step and not (space._bodies_to_check or space._removed_shapes):
            # pymunk's step without its Python bookkeeping (no callbacks are registered)
            _step_space(space._space, step_s)
        else:  # after a human came or left: pymunk checks new bodies, forgets removed shapes
            space.step(step_s)
        self._reader.read()
        if self._robot.motion is not before:
            self._count_odometer(before)
        self._reclamp_robot()
        for thing in self.things:
            if thing.motion is not thing.rested:  # untouched since it stopped: nothing to do
                self._roll(thing)
        contacts, ended, left = self._contacts(time_ms)
        self.last_report = StepReport(
            tick=tick, time_ms=time_ms, contacts=contacts, ended=ended, left=left
        )
        return self.last_report

    def _count_odometer(self, before: Motion) -> None:
        """Add the step's motion (from ``before``) to the odometer, in the robot's frame after
        the step (a push and a blocked drive are in it: the base's wheels go as it goes)."""
        after = self._robot.motion
        dx, dy = after.x_m - before.x_m, after.y_m - before.y_m
        cos, sin = math.cos(after.angle_rad), math.sin(after.angle_rad)
        forward, left, turn = self.odometer
        self.odometer = (
            forward + cos * dx + sin * dy,
            left + cos * dy - sin * dx,
            turn + after.angle_rad - before.angle_rad,
        )

    def _drive_robot(self, outputs: ActuatorOutputs) -> None:
        top, top_spin, limit, turn_limit = self._limits
        motion = self._robot.motion
        vx, vy = capped(outputs.v_x, outputs.v_y, top)
        omega = min(max(outputs.v_theta, -top_spin), top_spin)
        cos, sin = math.cos(motion.angle_rad), math.sin(motion.angle_rad)
        want_x, want_y = cos * vx - sin * vy, sin * vx + cos * vy
        dx, dy = want_x - motion.vx_mps, want_y - motion.vy_mps
        change = math.hypot(dx, dy)
        if change > limit:
            dx, dy = dx * limit / change, dy * limit / change
        want_x, want_y = capped(motion.vx_mps + dx, motion.vy_mps + dy, top)
        turn = min(max(omega - motion.omega_radps, -turn_limit), turn_limit)
        self._robot.drive(want_x, want_y, motion.omega_radps + turn)

    def _reclamp_robot(self) -> None:
        """A push during the step (a human walking into the robot) leaves it at most at its
        speed limits: the drive brakes it back at once."""
        top, motion = self._limits[0], self._robot.motion
        vx, vy = motion.vx_mps, motion.vy_mps
        if math.hypot(vx, vy) > top:  # (its infinite moment keeps its spin)
            self._robot.drive(*capped(vx, vy, top), motion.omega_radps)

    def _roll(self, thing: Thing) -> None:
        """Rolling resistance: exponential damping plus a constant deceleration."""
        motion = thing.motion
        vx, vy = motion.vx_mps, motion.vy_mps
        speed = math.sqrt(vx**2 + vy**2)
        slower = speed * thing.keep - thing.slowing
        if slower <= STOP_SPEED_MPS:
            vx, vy = 0.0, 0.0
        else:
            factor = slower / speed
            vx, vy = vx * factor, vy * factor
        spin = motion.omega_radps * thing.keep
        spin = spin if abs(spin) > STOP_SPEED_MPS else 0.0
        thing.drive(vx, vy, spin)
        # stopped (+0.0 each): rolling this motion again would drive the same zeros
        thing.rested = thing.motion if not (vx or vy or spin) else None

    def _contacts(
        self, time_ms: int
    ) -> tuple[tuple[str, ...], tuple[ContactSpan, ...], tuple[str, ...]]:
        """Who touches the robot after the step, whose contact ended and who left the room
        (taken out of the space: reached the exit during this step)."""
        robot = self.robot_motion
        robot_x, robot_y = robot.x_m, robot.y_m
        radius = self.scenario.robot.radius_m
        starts = self._contact_start_ms
        touching = []
        ended = []
        left = []
        sqrt = math.sqrt
        for human in self.humans:
            ident, present = human.ident, human.present
            if present and human.driver.left:
                self.space.remove(human.body, human.shape)
                human.present = present = False
                self._reader.moved_bodies()
                left.append(ident)
            # pymunk's (a - b).length, written out on the cached floats
            x, y = human.xy
            dx, dy = x - robot_x, y - robot_y
            gap = sqrt(dx**2 + dy**2) - radius - human.radius_m
            if present and gap <= CONTACT_TOLERANCE_M:
                touching.append(ident)
                if ident not in starts:
                    starts[ident] = time_ms
            elif ident in starts:
                start = starts.pop(ident)
                ended.append(
                    ContactSpan(
                        human=ident,
                        touchtype=str(human.spec.touchtype),
                        startingtime_ms=start,
                        duration_ms=time_ms - start,
                    )
                )
        return tuple(touching), tuple(ended), tuple(left)

    # ------------------------------------------------------------- events

    def apply_event(self, event: BehaviourEvent) -> None:
        """A behaviour event: the named human starts the given segment at the next step."""
        for human in self.humans:
            if human.spec.id == event.human:
                human.driver.switch(event.segment)
                return
        raise KeyError(event.human)

    # -------------------------------------------------------------- reading

    def robot_pose(self) -> tuple[float, float, float]:
        """Robot ``(x_m, y_m, theta_rad)``, theta wrapped to (-pi, pi]."""
        motion = self.robot_motion
        return (motion.x_m, motion.y_m, wrap_angle(motion.angle_rad))

    def robot_body_velocity(self) -> tuple[float, float, float]:
        """Robot velocity in its own frame: ``(forward_mps, left_mps, omega_radps)``."""
        motion = self.robot_motion
        cos, sin = math.cos(motion.angle_rad), math.sin(motion.angle_rad)
        return (
            cos * motion.vx_mps + sin * motion.vy_mps,
            -sin * motion.vx_mps + cos * motion.vy_mps,
            self.robot_motion.omega_radps,
        )

    def human_positions(self) -> list[tuple[str, float, float]]:
        """``(id, x_m, y_m)`` of the humans in the room, in the scenario's order."""
        return [
            (human.spec.id, human.motion.x_m, human.motion.y_m)
            for human in self.humans
            if human.present
        ]

    def object_positions(self) -> list[tuple[str, float, float]]:
        """``(id, x_m, y_m)`` of the objects, in the scenario's order."""
        return [(thing.spec.id, thing.motion.x_m, thing.motion.y_m) for thing in self.things]

    def state(self, *, tick: int, time_ms: int) -> WorldState:
        """Everything that moves, for ``/world/state``.

        Each body's entry is rebuilt only when its inputs changed (a new ``Motion``,
        a human's new heading): a body at rest reuses the one it had, bit for bit."""
        robot = self._robot
        if robot.motion is not robot.state_of:
            robot.state = rigid_state("robot", "robot", robot.motion, self.scenario.robot.radius_m)
            robot.state_of = robot.motion
        return WorldState(
            tick=tick,
            time_ms=time_ms,
            robot=robot.state,
            humans=tuple([human.entry() for human in self.humans if human.present]),
            objects=tuple(
                [
                    thing.state if thing.motion is thing.state_of else thing_state(thing)
                    for thing in self.things
                ]
            ),
            led=self.led,
            audio=self.audio,
            contacts=self.last_report.contacts,
        )
