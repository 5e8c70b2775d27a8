"""The world's moving bodies as Python sees them, and their ``/world/state`` entries.

Each pymunk property read or set is a C call (and a new ``Vec2d``). So the world reads
every body at once after a step (``BodyReader``: one call of ``pymunk.batch``'s C
iterator, into bytes); a body whose bytes did not change keeps its ``Motion`` object,
so ``motion is last`` means "unchanged to the bit"; a velocity is set only when its
bits change (``Mover.drive``); and a body's ``/world/state`` entry is rebuilt only when
what it is made from changed, with ``rounded`` (``round``, bit for bit, faster). The
bytes are those pymunk's properties and ``round`` would give.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Iterable
from typing import Final, NamedTuple

import pymunk
import pymunk.batch
from oimi.pipeline.events import BodyState
from oimi.scenarios.schema import HumanSpec, ObjectSpec
from oimi.scenarios.simulation.humans import STILL, HumanDriver
from pymunk._chipmunk import ffi as _ffi
from pymunk._chipmunk import lib as _chipmunk

STATE_DECIMALS: Final = 3
"""``/world/state``'s resolution: millimetres and milliradians (per second for speeds),
finer than anything measured in a room (format 5; micrometres before). The physics runs at
full precision; the digits below this are what a recording's positions cost most (they
compress badly). Speeds are cut towards zero, so the record never shows a speed the robot
did not reach."""


class Motion(NamedTuple):
    """A body's position, angle, velocity and spin as read after a step (in the order of
    ``pymunk.batch``'s values for a body); everything else uses this copy."""

    x_m: float
    y_m: float
    angle_rad: float
    vx_mps: float
    vy_mps: float
    omega_radps: float

    @classmethod
    def of(cls, body: pymunk.Body) -> Motion:
        """Read one body (when the world is built)."""
        (x, y), (vx, vy) = body.position, body.velocity
        return cls(x, y, body.angle, vx, vy, body.angular_velocity)


_MOTION_FIELDS: Final = (
    pymunk.batch.BodyFields.POSITION
    | pymunk.batch.BodyFields.ANGLE
    | pymunk.batch.BodyFields.VELOCITY
    | pymunk.batch.BodyFields.ANGULAR_VELOCITY
)
_MOTION: Final = struct.Struct(f"{len(Motion._fields)}d")
"""One body's values in the batch's float array (``cpFloat`` is a C double)."""
_FLOAT_SIZE: Final = _ffi.sizeof("cpFloat")
_ID_SIZE: Final = _ffi.sizeof("uintptr_t")
assert _FLOAT_SIZE == 8 and memoryview(b"").cast("P").itemsize == _ID_SIZE
_READ_BODY: Final = _ffi.addressof(_chipmunk, "pmSpaceBodyGetIteratorFuncBatched")
_set_velocity: Final = _chipmunk.cpBodySetVelocity
_set_spin: Final = _chipmunk.cpBodySetAngularVelocity
_each_body: Final = _chipmunk.cpSpaceEachBody
_buffer: Final = _ffi.buffer
"""Chipmunk's and cffi's functions the world calls at every step, looked up once (each
lookup on cffi's ``lib`` is a call of its own)."""
_VELOCITY: Final = slice(3 * _FLOAT_SIZE, 5 * _FLOAT_SIZE)
_SPIN: Final = slice(5 * _FLOAT_SIZE, 6 * _FLOAT_SIZE)
"""Where a body's velocity and spin are in its bytes (``Motion``'s order)."""


class Mover:
    """A body that moves, its motion as last read and its ``/world/state`` entry.

    ``raw`` is the motion's bytes as chipmunk wrote them; ``state`` is built from
    ``state_of`` (the inputs it was made from, compared by identity) and reused
    while they are the same objects, so a body at rest costs no rounding.
    """

    def __init__(self, body: pymunk.Body):
        self.body = body
        self.cp_body = body._body
        """Chipmunk's body, to set its velocity without pymunk's property glue."""
        self.motion = Motion.of(body)
        self.xy: tuple[float, float] = (self.motion.x_m, self.motion.y_m)
        self.raw = b""
        self.state: BodyState | None = None
        self.state_of: object = None

    def drive(self, vx_mps: float, vy_mps: float, omega_radps: float) -> None:
        """Give the body this velocity and spin, and keep ``motion`` and ``raw`` what chipmunk
        holds: only a value whose bits change is set (each set is a C call). Called only
        while they hold it (after a read, or a drive, with no other change since)."""
        motion = self.motion
        values = (motion.x_m, motion.y_m, motion.angle_rad, vx_mps, vy_mps, omega_radps)
        raw, last = _MOTION.pack(*values), self.raw
        if raw != last:
            if raw[_VELOCITY] != last[_VELOCITY]:
                _set_velocity(self.cp_body, (vx_mps, vy_mps))
            if raw[_SPIN] != last[_SPIN]:
                _set_spin(self.cp_body, omega_radps)
            self.raw, self.motion = raw, tuple.__new__(Motion, values)


class Robot(Mover):
    """The robot's body and its motion as last read (like ``Human`` and ``Thing``)."""


class Human(Mover):
    """A child or a therapist: its driver, and whether it is in the room."""

    def __init__(
        self, spec: HumanSpec, driver: HumanDriver, body: pymunk.Body, shape: pymunk.Shape
    ):
        super().__init__(body)
        self.spec = spec
        self.ident, self.kind, self.radius_m = spec.id, str(spec.role), spec.radius_m
        self.driver = driver
        self.velocity = STILL
        """The velocity last set (nothing else changes a kinematic body's)."""
        self.shape = shape
        self.present = True
        self.heading_of: float | None = None
        """The driver's heading ``state`` was built from (with ``state_of``, the motion)."""

    def steer(self, robot_xy: tuple[float, float], time_ms: int, step_s: float) -> bool:
        """Give the body the velocity its driver wants for the step starting at ``time_ms``
        (a human out of the room stands); whether it comes back into the room (the world
        puts it back in its space)."""
        driver = self.driver
        velocity = driver.velocity(self.xy, robot_xy, time_ms, step_s)
        back = False
        if not self.present:
            if driver.left:
                velocity = STILL
            else:
                self.present = back = True
        # set only when changed (a standing human's stays set); equal floats are the
        # same bits but for a zero's sign, so equal zeros count only as the same object
        last = self.velocity
        if velocity is not last and (velocity != last or 0.0 in velocity):
            _set_velocity(self.cp_body, velocity)
            self.velocity = velocity
        return back

    def entry(self) -> BodyState:
        """Its ``/world/state`` entry, facing where its driver heads: the one it had while
        its motion and heading are the same objects, else a new one (kept)."""
        motion, heading, last = self.motion, self.driver.heading_rad, self.state
        if motion is self.state_of and heading is self.heading_of:
            return last  # type: ignore[return-value]  # (state_of is set with state)
        x, y, _, vx, vy, _ = motion
        if last is not None and heading == self.heading_of and heading:  # the same bits
            theta = last.theta_rad  # (a walk straight on keeps its heading)
        else:
            theta = rounded(heading, STATE_DECIMALS)
        self.state = last = BodyState(
            id=self.ident,
            kind=self.kind,
            x_m=rounded(x, STATE_DECIMALS),
            y_m=rounded(y, STATE_DECIMALS),
            theta_rad=theta,
            vx_mps=int(vx * _SCALE) / _SCALE,
            vy_mps=int(vy * _SCALE) / _SCALE,
            radius_m=self.radius_m,
        )
        self.state_of, self.heading_of = motion, heading
        return last


class Thing(Mover):
    """An object (a ball): it rolls to a stop."""

    def __init__(self, spec: ObjectSpec, body: pymunk.Body, step_s: float):
        super().__init__(body)
        self.spec = spec
        self.keep = spec.damping_per_s**step_s
        """Fraction of speed kept per step."""
        self.slowing = spec.rolling_decel_mps2 * step_s
        """Speed lost per step to rolling resistance."""
        self.rested: Motion | None = None
        """The motion it came to rest in (no velocity, no spin), while it keeps it: rolling
        resistance leaves a body at rest as it is, so the world skips it."""


class BodyReader:
    """Reads the motion of every mover in a space after a step (see the module)."""

    def __init__(self, space: pymunk.Space, movers: Iterable[Mover]):
        self.space = space
        self._movers = {mover.body.id: mover for mover in movers}
        self._batch = pymunk.batch.Buffer()
        self._floats = self._batch._float_arr
        self._request = _ffi.new("pmBatchedData *")
        """``pymunk.batch.get_space_bodies``'s request, made once (it builds one per call)."""
        self._request.fields = _MOTION_FIELDS.value
        self._request.floatArray = self._floats
        self._request.intArray = self._batch._int_arr
        self._bodies = -1
        """How many bodies the space had when the layout was worked out (-1: work it out
        again; see ``moved_bodies``)."""
        self._layout: list[tuple[int, int, Mover]] = []
        """Where each mover's values are in the last read (byte offsets)."""

    def moved_bodies(self) -> None:
        """A body was added to the space or removed from it: the space's order changed."""
        self._bodies = -1

    def read(self) -> None:
        """Read every body's motion after a step (nothing else moves them between steps).

        One call of ``pymunk.batch``'s C iterator for the whole space (furniture too,
        skipped); a mover whose bytes did not change keeps its ``Motion`` object. A
        human out of the room is not in the space and keeps the motion it left with.
        Where each body's values are is worked out again only after ``moved_bodies``
        (or when the number of bodies changed).
        """
        space = self.space
        # (pymunk's own dict of them: its ``bodies`` property is a Python call)
        if len(space._bodies) != self._bodies:  # a human left or came back
            self._layout_of_bodies()
        floats = self._floats
        floats.num = 0
        _each_body(space._space, _READ_BODY, self._request)
        raw = _buffer(floats.arr, floats.num * _FLOAT_SIZE)[:]
        unpack, make = _MOTION.unpack, tuple.__new__
        for start, end, mover in self._layout:
            chunk = raw[start:end]
            if chunk != mover.raw:
                mover.raw = chunk
                values = unpack(chunk)
                mover.motion = make(Motion, values)  # without Motion's Python-level __new__
                mover.xy = values[:2]

    def _layout_of_bodies(self) -> None:
        """Where each mover's values are in the space's order of bodies."""
        self._bodies = len(self.space.bodies)
        buffer = pymunk.batch.Buffer()
        pymunk.batch.get_space_bodies(self.space, pymunk.batch.BodyFields.BODY_ID, buffer)
        ids = memoryview(buffer.int_buf()).cast("P").tolist()
        size = _MOTION.size
        self._layout = [
            (index * size, (index + 1) * size, mover)
            for index, ident in enumerate(ids)
            if (mover := self._movers.get(ident)) is not None
        ]


def thing_state(thing: Thing) -> BodyState:
    """An object's ``/world/state`` entry, kept in ``thing``."""
    spec, motion = thing.spec, thing.motion
    thing.state = rigid_state(spec.id, spec.category, motion, spec.radius_m)
    thing.state_of = motion
    return thing.state


def rigid_state(ident: str, kind: str, motion: Motion, radius_m: float) -> BodyState:
    """A body that turns with its physics (the robot, an object) at ``/world/state``'s
    resolution."""
    return BodyState(
        id=ident,
        kind=kind,
        x_m=rounded(motion.x_m, STATE_DECIMALS),
        y_m=rounded(motion.y_m, STATE_DECIMALS),
        theta_rad=rounded(wrap_angle(motion.angle_rad), STATE_DECIMALS),
        vx_mps=int(motion.vx_mps * _SCALE) / _SCALE,
        vy_mps=int(motion.vy_mps * _SCALE) / _SCALE,
        omega_radps=int(motion.omega_radps * _SCALE) / _SCALE,
        radius_m=radius_m,
    )


_SCALE: Final = float(10**STATE_DECIMALS)
"""Speeds are cut towards zero as ``int(speed * _SCALE) / _SCALE``."""
_SCALES: Final = {decimals: float(10**decimals) for decimals in range(16)}


def rounded(value: float, decimals: int) -> float:
    """``round(value, decimals)`` (0 to 15 decimals, else ``KeyError``), bit for bit, in
    under half its time.

    ``round`` finds the integer ``k`` nearest the exact ``value * 10**decimals`` (ties to
    even) and returns the float nearest ``k / 10**decimals``. Below 1e11, the computed
    product is within 1e-4 of the exact one (its error is at most half an ulp, under
    2**-53 of it): when it is more than 1e-4 from a half, the integer nearest it is that
    ``k``, and dividing it by the (exact) scale is correctly rounded: the same float. That
    integer is found in floats, with no int made: below 2**51, adding and taking away
    1.5 * 2**52 rounds a float to the nearest integer (the sum's spacing is 1), exactly.
    Near a half, at zero (its sign), for a huge or non-finite value, it asks ``round``.
    """
    scale = _SCALES[decimals]
    scaled = value * scale
    if -1e11 < scaled < 1e11:
        nearest = (scaled + 6755399441055744.0) - 6755399441055744.0  # 1.5 * 2**52
        if nearest and -0.4999 < scaled - nearest < 0.4999:
            return nearest / scale
    return round(value, decimals)


def wrap_angle(angle_rad: float) -> float:
    """The angle in (-pi, pi]."""
    wrapped = _remainder(angle_rad, _TAU)
    return _PI if wrapped == _MINUS_PI else wrapped


_remainder: Final = math.remainder
_TAU: Final = math.tau
_PI: Final = math.pi
_MINUS_PI: Final = -math.pi
"""``wrap_angle``'s function and constants, looked up once (it runs for every reading)."""
