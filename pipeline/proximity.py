"""Surface distances, proxemic zones and contact episodes between the robot and each human.

The one definition shared by ``oimi run``'s summary and expectations
(``scenarios.session.expectations``) and by ``oimi analyse`` (``analysis``): both feed
:class:`ProximityTracker` one ``/world/state`` message per tick. It lives in
``pipeline`` because it is pure geometry on ``pipeline.events`` messages, which
every other package may import (``pipeline`` itself imports none of them).

Distances are surface to surface: the centres' distance less both radii (the
radii are the recorded ``BodyState.radius_m``), so touching is 0 m and bodies
pressed into each other are slightly negative.
"""

from __future__ import annotations

import bisect
import enum
import math
from typing import Final

import msgspec
from oimi.pipeline.events import ActuatorCommands, BodyState, WorldState
from oimi.pipeline.messages import MoveCommand

ZONES_M: Final = (
    ("contact", -math.inf, 0.0),
    ("intimate", 0.0, 0.45),
    ("personal", 0.45, 1.2),
    ("social", 1.2, 3.6),
    ("public", 3.6, math.inf),
)
"""Hall's proxemic zones on the surface distance, ``(name, from, to)`` with ``from < d <= to``
for contact and ``from <= d < to`` for the others (m)."""

ZONE_NAMES: Final = tuple(name for name, _, _ in ZONES_M)

MERGE_MS: Final = 200
"""Contacts separated by less than this are one episode (bodies bounce apart for a tick)."""
ROLL_MS: Final = 1000
"""How long a robot pushed may roll on once the push ended: a push of 1 m/s (a walking
child's) braked at the base's 1 m/s²."""


class Initiator(enum.StrEnum):
    """Who closed the gap at the start of a contact."""

    ROBOT = "robot"
    """The robot moved towards the person faster than the person moved towards it (and it
    was not :attr:`PUSHED`)."""
    PERSON = "person"
    """The person moved towards the robot at least as fast (a standing robot never initiates)."""
    PUSHED = "pushed"
    """The robot moved towards the person faster, but another person was pressing into it,
    or did within :data:`ROLL_MS` (it rolled on from the push), and its own drive (its move
    commands since) did not point towards this one: it was pushed into them."""


def surface_distance(robot: BodyState, human: BodyState) -> float:
    """Surface-to-surface distance, m (negative when the bodies overlap)."""
    return surface_gap(math.hypot(human.x_m - robot.x_m, human.y_m - robot.y_m), robot, human)


def surface_gap(centres_m: float, robot: BodyState, human: BodyState) -> float:
    """The surface-to-surface distance of two bodies whose centres are ``centres_m`` apart."""
    return centres_m - robot.radius_m - human.radius_m


_UPPER_BOUNDS_M: Final = tuple(high for _, _, high in ZONES_M[1:-1])
"""Where each zone after ``contact`` ends, but the last (which has none)."""


def zone_of(distance_m: float) -> str:
    """The :data:`ZONES_M` name of a surface distance (NaN counts as ``public``)."""
    if distance_m <= 0.0:
        return "contact"
    return ZONE_NAMES[1 + _bisect_right(_UPPER_BOUNDS_M, distance_m)]


_bisect_right: Final = bisect.bisect_right
"""Looked up once (``zone_of`` runs for every person at every tick)."""


def approach_speeds(robot: BodyState, human: BodyState) -> tuple[float, float]:
    """``(robot towards human, human towards robot)``, m/s: each body's velocity projected on
    the line between the centres (positive = closing the gap)."""
    dx, dy = human.x_m - robot.x_m, human.y_m - robot.y_m
    norm = math.hypot(dx, dy)
    if norm == 0.0:
        return (0.0, 0.0)
    ux, uy = dx / norm, dy / norm
    return (robot.vx_mps * ux + robot.vy_mps * uy, -(human.vx_mps * ux + human.vy_mps * uy))


class ContactEpisode(msgspec.Struct, frozen=True, kw_only=True):
    """One contact between the robot and a person, from first touch to separation."""

    human: str
    kind: str
    start_ms: int
    end_ms: int
    """When the bodies were last in contact, plus one tick."""
    robot_speed_mps: float
    """The robot's speed towards the person just before contact (m/s, negative = away)."""
    person_speed_mps: float
    """The person's speed towards the robot just before contact (m/s)."""
    initiator: Initiator
    min_surface_distance_m: float
    """The deepest the bodies were pressed into each other during the episode (<= 0)."""

    @property
    def duration_ms(self) -> int:
        return self.end_ms - self.start_ms

    @property
    def closing_speed_mps(self) -> float:
        """The speed at which the gap closed just before contact (both speeds summed)."""
        return self.robot_speed_mps + self.person_speed_mps


class _Open(msgspec.Struct, kw_only=True):
    episode: ContactEpisode
    last_ms: int
    deepest: float


class ProximityTracker:
    """Per human: closest surface (and centre) distance, time in each zone, and contact
    episodes.

    Feed it every ``WorldState`` in order (:meth:`update`), or a recording's samples of
    them (a state counts in its zone for the time since the one before), then
    :meth:`finish`; memory is one entry per human plus the episodes found. ``zones=False``
    counts no time in zones (``zone_ms`` stays empty: the expectations read none).
    """

    def __init__(self, *, tick_ms: int, zones: bool = True) -> None:
        self.tick_ms = tick_ms
        self.zones = zones
        self.kinds: dict[str, str] = {}
        self.closest_m: dict[str, float] = {}
        self.closest_centres_m: dict[str, float] = {}
        """Closest centre-to-centre distance; unlike ``closest_m``, a NaN position sticks
        (an expectation on it must fail, not skip the tick)."""
        self.closest_at_ms: dict[str, int] = {}
        self.zone_ms: dict[str, dict[str, int]] = {}
        self.episodes: list[ContactEpisode] = []
        self._open: dict[str, _Open] = {}
        self._previous: WorldState | None = None
        """The state before the one being read: where a contact's speeds are taken."""
        self._drive: tuple[float, float] = (0.0, 0.0)
        """The robot's own drive: its last move command's velocity (body frame, m/s)."""
        self._pressed: tuple[int, str] | None = None
        """When a person last pressed into the robot, and who (within :data:`ROLL_MS`)."""
        self._drives_since: list[tuple[float, float]] = []
        """The drives the robot had since that press."""

    def command(self, message: ActuatorCommands) -> None:
        """Note the robot's move commands (its own drive, which tells a robot that drove
        into a person from one pushed into them); feed them in order with the states."""
        for command in message.commands:
            if type(command) is MoveCommand:
                self._drive = (0.0, 0.0) if command.stop else (command.v_x, command.v_y)
                if self._pressed is not None:
                    self._drives_since.append(self._drive)

    def update(self, state: WorldState) -> None:
        robot, now = state.robot, state.time_ms
        lasted = self.tick_ms if self._previous is None else now - self._previous.time_ms
        kinds, closest_m, zone_ms = self.kinds, self.closest_m, self.zone_ms
        centres_m, x, y, hypot, isnan, inf = (
            self.closest_centres_m,
            robot.x_m,
            robot.y_m,
            math.hypot,
            math.isnan,
            math.inf,
        )
        contacts, open_, count_zones = state.contacts, self._open, self.zones
        for human in state.humans:
            who = human.id
            if who not in kinds:  # first seen
                kinds[who] = human.kind
                centres_m[who] = math.inf
                if count_zones:
                    zone_ms[who] = dict.fromkeys(ZONE_NAMES, 0)
            centres = hypot(human.x_m - x, human.y_m - y)
            if not centres >= (closest := centres_m[who]) and not isnan(closest):
                centres_m[who] = centres
            distance = surface_gap(centres, robot, human)
            if distance < closest_m.get(who, inf):
                closest_m[who], self.closest_at_ms[who] = distance, now
            if count_zones:
                zone_ms[who][zone_of(distance)] += lasted
            if distance <= 0.0 or who in contacts:
                self._touch(who, human, robot, now, distance)
            elif open_ and who in open_ and now - open_[who].last_ms > MERGE_MS:
                self._close(who)
        if contacts:
            self._note_press(state)
        if self._pressed is not None and now - self._pressed[0] > ROLL_MS:
            self._pressed, self._drives_since = None, []  # (a touch that presses no more)
        self._previous = state

    def _note_press(self, state: WorldState) -> None:
        """Note a person touching the robot and moving into it (a push)."""
        for human in state.humans:
            if human.id in state.contacts and approach_speeds(state.robot, human)[1] > 0.0:
                self._pressed, self._drives_since = (state.time_ms, human.id), [self._drive]

    def _touch(self, who: str, human: BodyState, robot: BodyState, now: int, d: float) -> None:
        if (open_ := self._open.get(who)) is not None:
            open_.last_ms, open_.deepest = now, min(open_.deepest, d)
            return
        before_robot, before_human = robot, human  # first seen touching: no speeds before
        if (previous := self._previous) is not None:
            for body in previous.humans:
                if body.id == who:
                    before_robot, before_human = previous.robot, body
                    break
        robot_speed, person_speed = approach_speeds(before_robot, before_human)
        initiator = Initiator.PERSON
        if robot_speed > person_speed:
            pushed = previous is not None and self._pushed(previous, before_human)
            initiator = Initiator.PUSHED if pushed else Initiator.ROBOT
        episode = ContactEpisode(
            human=who,
            kind=human.kind,
            start_ms=now,
            end_ms=now + self.tick_ms,
            robot_speed_mps=round(robot_speed, 4),
            person_speed_mps=round(person_speed, 4),
            initiator=initiator,
            min_surface_distance_m=round(d, 4),
        )
        self._open[who] = _Open(episode=episode, last_ms=now, deepest=d)

    def _pushed(self, previous: WorldState, human: BodyState) -> bool:
        """Whether, at ``previous``, another person pressed into the robot, or had within
        :data:`ROLL_MS`, while none of the robot's own drives since that press (the one at
        ``previous`` among them) pointed towards ``human``: then it was pushed."""
        pressed = self._pressed
        if pressed is None or pressed[1] == human.id or previous.time_ms - pressed[0] > ROLL_MS:
            return False
        robot = previous.robot
        dx, dy = human.x_m - robot.x_m, human.y_m - robot.y_m
        cos, sin = math.cos(robot.theta_rad), math.sin(robot.theta_rad)
        return not any(  # a drive towards them: its own doing, pushed or not
            (v_x * cos - v_y * sin) * dx + (v_x * sin + v_y * cos) * dy > 0.0
            for v_x, v_y in self._drives_since
        )

    def _closed(self, open_: _Open) -> ContactEpisode:
        return msgspec.structs.replace(
            open_.episode,
            end_ms=open_.last_ms + self.tick_ms,
            min_surface_distance_m=round(open_.deepest, 4),
        )

    def _close(self, who: str) -> None:
        self.episodes.append(self._closed(self._open.pop(who)))

    def finish(self) -> list[ContactEpisode]:
        """Every episode so far in start order, those still open ending at the last tick seen
        (they stay open: more updates may follow)."""
        ongoing = [self._closed(self._open[who]) for who in sorted(self._open)]
        return sorted([*self.episodes, *ongoing], key=lambda e: (e.start_ms, e.human))
