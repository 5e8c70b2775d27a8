"""The safety supervisor: speed and separation monitoring below every source of motion.

In the spirit of ISO 13482 and ISO/TS 15066, it limits the robot's velocity *towards* each
human by their surface-to-surface distance ``s``, taken from the map the sensors alone made
(``MapProducer.perceived``: never the simulator's truth, nothing a rule or script wrote).
docs/actuator-and-joystick.md tells it whole; in short:

| zone (surface distance ``s``)      | velocity towards the human                      |
|------------------------------------|-------------------------------------------------|
| ``s >= slow_distance_m``           | free (up to what the robot can brake before the stop zone) |
| ``stop_distance_m <= s < slow``    | at most ``slow_speed_mps``, and braking room    |
| ``s < stop_distance_m``            | none: a protective stop of the closing component |

A protective stop holds until ``s`` is halfway back to the slow zone (hysteresis: the
margin shrinks with each camera frame). Moving away and sideways stays allowed while the
base, braking, stands before the human could walk into the stop zone. ``s`` is
the centre distance less both radii and a margin ``sensing_error_m + human_speed_mps * (age
+ one tick)`` (age capped at ``max_data_age_ms``); between readings the robot's own motion
is dead-reckoned, its base taken to follow what is let through at ``max_accel_mps2`` and
``max_angular_accel_radps2`` (a cut or a spin's end is braked to, not taken at once; the
velocity it will have after the tick must meet the limits too: a base spinning under a
command lags it most), and
while a sonar is down the margin grows by the slip the robot's measured speed shows since
the reading, and by a push no report covers yet (``pipeline/act/reckoning.py``: a base
blocked by furniture or pushed).
Braking room: ``c * dt + (c + 2 walk) * speed / (2 a) <= s - stop``, a tick at ``c``,
then the base braking its whole velocity at ``a`` while the human walks on (``speed`` taken
as ``c`` plus what moves across: ``pipeline/act/separation.py``). Inside the stop zone,
or moving sideways too near to stand in time, ``v`` may not point at any point the human
may reach while the base brakes from it (a cone, wider with the speed).

Sensing: a camera offline (or none), every sonar down, or a human's reading older than
``max_data_age_ms`` (or from more than a tick ahead) caps linear motion at
``slow_speed_mps`` (a human the camera stopped reporting, on a ring that reports every body
apart: only until it has scanned since, then their echo stands in for them); no sensor on:
none. A sensor is on only while its status keeps coming (``max_status_age_ms``; three
quarters of it late: slow) and a sonar only while its heartbeat does (``scantime`` within
``max_scan_age_ms``: a ring frozen on an empty room still says it is on), and a camera only
while its frames do (``frametime`` within ``max_frame_age_ms``). The ring's echoes
(obstacles not fixed) are kept as anonymous humans unless a fresh reading of a tracked human
explains them (``pipeline/act/echoes.py``: where the camera saw all the beam that made one,
or one each on an ideal ring); one no longer reported is gone once every sonar has scanned
since and ``echo_hold_ms`` have passed; one repeated with an old reading, or that a ring now
down may have made, is kept, stale. While a sonar is down, repeats an old echo, or is back
for less than ``sonar_miss_ms`` (``pipeline/act/looking.py``), linear motion stays inside
the camera's view, narrowed so that a child centred just outside it beyond the slow zone
is not driven into the stop zone; a camera too short-ranged to report a child ahead in
time leaves none (``safety_config.ring_down_view_rad``), and so does one that does not
look (offline, frozen), or not yet for ``camera_miss_ms`` since it came back.

It is not a rule: the loop calls it after the actuator every tick, and no alfa/omega
message, script or joystick input reaches it. No clock, no IO.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from math import cos, hypot, sin
from typing import Final, NamedTuple

from oimi.pipeline.act.echoes import Anchor, EchoSorter, estimate
from oimi.pipeline.act.limits import RobotLimits, Velocity, fields
from oimi.pipeline.act.looking import SensorWatch
from oimi.pipeline.act.reckoning import DeadReckoning
from oimi.pipeline.act.safety_config import SafetyConfig, ring_down_view_rad, safety_problems
from oimi.pipeline.act.separation import (
    Constraint,
    braking_cap,
    clear_gap,
    followed_meeting,
    meeting,
    nearer,
    stopping_way,
    within_view,
)
from oimi.pipeline.events import MotionSource, SafetyIntervention, SafetyPhase, SafetyZone
from oimi.pipeline.messages import Camera, Entity, Obstacle, Sonar, WorldMap

_NEVER: Final = -math.inf
"""When a sensor never heard from last reported (before any time)."""


class Verdict(NamedTuple):
    """The supervisor's answer for one tick."""

    velocity: Velocity
    """What may be driven (equal to the request when nothing was limited)."""
    zone: SafetyZone | None = None
    """Why it was limited; None: not limited."""
    human: str = ""
    """The human whose separation bound it (empty for blind/stale caps)."""
    surface_distance_m: float | None = None
    """That human's conservative surface distance, m."""

    @property
    def limited(self) -> bool:
        return self.zone is not None


class Supervised(NamedTuple):
    """A tick's verdict and, when an episode started, changed or ended, its event."""

    verdict: Verdict
    event: SafetyIntervention | None = None


_STOP: Final = SafetyZone.STOP
_SLOW: Final = SafetyZone.SLOW
"""(Module names: a member read through its enum class takes a slow path, for each human.)"""
EPISODE_GAP_MS: Final = 500
"""An intervention episode ends after this long without a limited tick."""
_SEVERITY: Final = {
    SafetyZone.BLIND: 1,
    SafetyZone.STALE: 1,
    SafetyZone.SLOW: 2,
    SafetyZone.STOP: 3,
}


class SafetySupervisor:
    """Limits each tick's velocity by the map's humans; dead-reckons between readings."""

    def __init__(self, config: SafetyConfig, limits: RobotLimits, *, tick_ms: int) -> None:
        problems = list(safety_problems(config))
        if problems:
            raise ValueError(problems[0][1])
        self.config = config = config.filled()
        self._limits = limits
        self._tick_ms = tick_ms
        self._dt_s = tick_ms / 1000
        self._step_m: float = limits.max_accel_mps2 * self._dt_s
        """The most the base's velocity changes in a tick, m/s."""
        self._walk: float = config.human_speed_mps  # type: ignore[assignment]  # filled
        """How fast a human may walk (``human_speed_mps``)."""
        self._echo_walk_ms: int = max(config.max_data_age_ms, config.echo_hold_ms)  # type: ignore[type-var,assignment]  # filled
        """How long the margin of an echo a working ring no longer reports grows with the
        walk: as long as the ring may keep it (``echo_hold_ms``; a stale reading's, a ring
        down or repeating itself, stops at ``max_data_age_ms``)."""
        self._release_m: float = (config.stop_distance_m + config.slow_distance_m) / 2  # type: ignore[operator]  # filled
        """Where a protective stop ends: halfway from the stop zone to the slow zone's edge."""
        self._cameras = SensorWatch(
            "Camera", config.max_frame_age_ms, config.camera_miss_ms, tick_ms
        )  # type: ignore[arg-type]  # filled
        self._sonars = SensorWatch("Sonar", config.max_scan_age_ms, config.sonar_miss_ms, tick_ms)  # type: ignore[arg-type]  # filled
        self._standing = Supervised(Verdict(Velocity()))
        """The last tick's answer to a request that stood (no linear velocity) with no
        event: handed on while the request is the same object (the actuator's, unchanged)."""
        self._reckoning = DeadReckoning(
            limits,
            tick_ms=tick_ms,
            kept_ms=2 * max(config.max_data_age_ms, config.max_status_age_ms),  # type: ignore[type-var]
            error=config.odometry_error,
            push_mps=config.human_speed_mps,  # type: ignore[arg-type]  # filled
        )
        """The robot's pose in its own start frame, and how far it may have slipped."""
        self._anchors: dict[str, Anchor] = {}
        """Human id (``Obstacle/<id>`` for an echo) -> its last reading in the odometry
        frame."""
        self._echoes = EchoSorter(config, self._reckoning, self._cameras)
        """Names the echoes, and tells which a tracked human explains."""
        self._held: dict[str, None] = {}
        """Humans under a protective stop: it holds until they are halfway out of the slow
        zone, so that the margin's saw-tooth between camera frames does not let the robot
        creep in, frame by frame (membership only, never iterated)."""
        self._episode: tuple[SafetyZone, str, MotionSource] | None = None
        """The intervention episode under way: its worst zone, that zone's human, the source."""
        self._limited_ms = 0
        """When the supervisor last changed a velocity."""
        self._looking_rad = ring_down_view_rad(
            config, limits.max_speed_mps, limits.max_accel_mps2, self._dt_s
        )
        """While the ring is down: how far from straight ahead the robot may drive, rad
        (negative: nowhere)."""

    def supervise(
        self,
        requested: Velocity,
        world_map: WorldMap,
        *,
        heard: Mapping[tuple[str, str], int],
        beats: Mapping[tuple[str, str], int],
        tick: int,
        now_ms: int,
        source: MotionSource,
    ) -> Supervised:
        """The velocity allowed at ``now_ms`` for ``requested`` (body frame, from ``source``);
        the robot is then taken to drive it for one tick (dead reckoning). ``heard``: when
        each sensor's status and each obstacle's reading was last heard, ms, by
        (``"Camera"``, ``"Sonar"`` or ``"Obstacle"``, id) (``MapProducer.heard``);
        ``beats``: when each sensor took its latest scan or frame, ms, by (``"Camera"`` or
        ``"Sonar"``, id) (``MapProducer.beats``)."""
        reckoning = self._reckoning
        reckoning.mark(now_ms)
        reckoning.measured(world_map.robotstatus.speed, now_ms)
        anchors = self._anchors
        # (most are placed already: tested inline, by field: compiled, anchor[0] is slow;
        # a key's test and item: compiled, dict.get is a method call)
        for human in world_map.humans:
            if human.poses:
                key = human.id
                if key not in anchors or anchors[key].stamp_ms != human.positionchangetime:
                    self._anchor(key, human, now_ms)
        framing = self._cameras.working(world_map.cameras, beats, now_ms)
        scanning = self._sonars.working(world_map.sonars, beats, now_ms)
        echoes = self._echoes.echoes(world_map)
        for key, echo in echoes:
            if key not in anchors or anchors[key].stamp_ms != echo.positionchangetime:
                self._anchor(key, echo, now_ms)
        verdict = self._limit(requested, world_map, echoes, framing, scanning, heard, beats, now_ms)
        reckoning.advance(verdict.velocity)
        phase = self._phase(verdict, source, now_ms)
        if phase is None:
            if verdict is self._standing.verdict:
                return self._standing
            return fields(Supervised, (verdict, None))
        assert self._episode is not None
        zone, human, source = self._episode
        if phase is SafetyPhase.END:
            self._episode = None
        event = SafetyIntervention(
            tick=tick,
            time_ms=now_ms,
            phase=phase,
            source=source,
            zone=zone,
            human=human,
            surface_distance_m=verdict.surface_distance_m,
            requested=tuple(requested),
            allowed=tuple(verdict.velocity),
        )
        return Supervised(verdict, event)

    @property
    def reckoned_pose(self) -> tuple[float, float, float]:
        """Where the dead reckoning has the robot, in its start frame (m, m, rad)."""
        return self._reckoning.pose

    # ---------------------------------------------------------------- internal

    def _phase(self, verdict: Verdict, source: MotionSource, now_ms: int) -> SafetyPhase | None:
        """Whether this tick starts, changes or ends an episode (None: none of these).

        An episode changes when its zone gets worse, its human or its source changes; it
        ends ``EPISODE_GAP_MS`` after the last limited tick, so a velocity that touches a
        limit on and off makes one episode, not one per touch."""
        episode = self._episode
        if verdict.zone is None:
            if episode is not None and now_ms - self._limited_ms >= EPISODE_GAP_MS:
                return SafetyPhase.END
            return None
        self._limited_ms = now_ms
        new = (verdict.zone, verdict.human, source)
        if episode is None:
            self._episode = new
            return SafetyPhase.START
        zone, human, was = episode
        worse = _SEVERITY[verdict.zone] > _SEVERITY[zone]
        other = verdict.zone is zone and verdict.human != human
        if worse or other or source is not was:
            self._episode = new
            return SafetyPhase.CHANGE
        return None

    def _limit(
        self,
        requested: Velocity,
        world_map: WorldMap,
        echoes: list[tuple[str, Entity]],
        framing: list[Camera],
        scanning: list[Sonar],
        heard: Mapping[tuple[str, str], int],
        beats: Mapping[tuple[str, str], int],
        now_ms: int,
    ) -> Verdict:
        if requested.v_x == 0.0 and requested.v_y == 0.0:  # a stand (or a turn on the spot)
            standing = self._standing.verdict  # is braked to straight: not limited
            if standing.velocity is not requested:
                standing = fields(Verdict, (requested, None, "", None))
                self._standing = fields(Supervised, (standing, None))
            return standing
        config = self.config
        sonars = world_map.sonars
        max_age = config.max_status_age_ms
        # A sensor counts only while its heartbeat says it works (frozen, it says it is on;
        # its frames or scans: SensorWatch.working)
        seeing = _online(framing, "Camera", heard, now_ms - max_age)
        sounding = _online(scanning, "Sonar", heard, now_ms - max_age)
        if not (seeing or sounding):  # no sensor says it is on: nothing senses the room
            return Verdict(Velocity(0.0, 0.0, requested.v_theta), SafetyZone.BLIND)
        late = _late(seeing + sounding, now_ms, max_age)
        blind = not seeing or (bool(sonars) and not sounding) or late
        # Since when every ring is known to scan (readings do not name their sonar): only
        # then does one that stopped reporting a body say it left (None: a ring is down).
        scanning_since = (
            min([beats[("Sonar", s.id)] for s in scanning])
            if len(sounding) == len(sonars) > 0 and not _late(sounding, now_ms, max_age)
            else None
        )
        stale = repeating = False
        echo_hold_ms = config.echo_hold_ms
        assert echo_hold_ms is not None  # filled
        placed: list[tuple[str, Entity, int]] = []  # what limits the robot, and its age
        kept: list[tuple[str, Entity, int]] = []  # the echoes kept, and their age
        for key, echo in echoes:
            age_ms = self._age(key, echo, now_ms)
            if age_ms > config.max_data_age_ms:
                reported_ms = heard.get(("Obstacle", echo.id), _NEVER)
                if now_ms - reported_ms <= config.max_data_age_ms:
                    stale = repeating = True  # an old reading repeated: a ring frozen, lagging
                elif _passed_over(scanning_since, reported_ms, now_ms, echo_hold_ms):
                    continue  # every ring said it was on since, and went on without it: gone
                elif scanning_since is None:
                    stale = True  # a ring down may have made it
            kept.append((key, echo, age_ms))
        # A ring down, or one repeating old readings (frozen: it says it is on, and may see
        # nothing new): nothing sees beside or behind the robot; drive where the camera looks.
        # So too while a ring back has not scanned for as long as it may miss a child.
        ring_down = scanning_since is None or repeating
        unsettled = ring_down or not self._sonars.settled(scanning, now_ms)
        # A human the camera stopped reporting is the ring's once it has scanned since, if
        # it reports every body apart (a merging ring may hide them behind nearer bodies)
        apart_since = None if unsettled or config.sonar_beam_rad else scanning_since
        seen: list[Anchor] = []  # fresh humans' anchors: what an echo may be
        for human in world_map.humans:
            if not human.poses:
                stale = True
                continue
            age_ms = self._age(human.id, human, now_ms)
            if age_ms <= config.max_data_age_ms:
                seen.append(self._anchors[human.id])
            else:
                reported_ms = heard.get(("Human", human.id), _NEVER)
                if _passed_over(apart_since, reported_ms, now_ms, config.max_data_age_ms):
                    continue  # lost: their echo says where they are, wherever they walk
                stale = True
            placed.append((human.id, human, age_ms))
        placed += self._echoes.unexplained(kept, seen, self._anchors, ring_down, framing)
        # Slip widens margins only then: a working ring sees where the bodies are, whatever
        # the reckoning says (its echoes are fresh); counted with it, a child's reading the
        # camera lost long ago would grow with every push until the robot froze
        v_x, v_y = requested.v_x, requested.v_y
        speed = hypot(v_x, v_y)
        zone: SafetyZone | None = None
        if (blind or stale) and speed > config.slow_speed_mps:
            scale = config.slow_speed_mps / speed
            v_x, v_y, speed = v_x * scale, v_y * scale, config.slow_speed_mps
            zone = SafetyZone.BLIND if blind else SafetyZone.STALE
        clear_m = self._clear_m(max(speed, self._reckoning.speed))  # (the base's: between)
        constraints = []
        for key, reading, age_ms in placed:
            constraint = self._constraint(key, reading, age_ms, ring_down, clear_m)
            if constraint is not None:
                constraints.append(constraint)
        # (the view only while the camera looks: offline or frozen, it sees nothing there;
        # back, only once it has framed for as long as its frames may miss a child)
        half_view = math.pi
        if sonars and unsettled:
            looked = seeing and self._cameras.looked(framing, now_ms)
            half_view = self._looking_rad if looked else -1.0
        looking = within_view(v_x, v_y, half_view)
        if looking != (v_x, v_y):
            v_x, v_y = looking
            zone = SafetyZone.BLIND
        v_x, v_y, binding = meeting(constraints, v_x, v_y, half_view)
        if constraints:  # the base lags its command (a spinning body's most): its velocity too
            top = config.slow_speed_mps if blind or stale else math.inf
            v_x, v_y, lagging = followed_meeting(
                constraints, v_x, v_y, half_view, self._reckoning.velocity, self._step_m, top
            )
            binding = nearer(binding, lagging)
        allowed = fields(Velocity, (v_x + 0.0, v_y + 0.0, requested.v_theta))
        if binding is not None:
            surface_m = round(binding.surface_m, 4)
            return fields(Verdict, (allowed, binding.zone, binding.human, surface_m))
        return fields(Verdict, (allowed, zone, "", None))

    def _age(self, key: str, reading: Entity, now_ms: int) -> int:
        """How long ago ``reading`` (placed as ``key``) was taken, ms: since its stamp, or
        since it came if that was earlier. One stamped more than a tick after ``now_ms``
        (a sensor whose clock is ahead of the session's) has no age that can be trusted:
        it is taken for stale, else it would look fresh until the clock caught up."""
        if reading.positionchangetime - now_ms > self._tick_ms:
            return self.config.max_data_age_ms + 1  # type: ignore[operator]  # filled
        return now_ms - self._anchors[key].at_ms

    def _clear_m(self, speed: float) -> float:
        """The surface distance beyond which a human sets no limit on a velocity of at most
        ``speed`` (``separation.clear_gap`` past the stop zone, outside the slow zone): the
        one asked for (capped when blind or stale) or the base's, whichever is faster (what
        the base takes for a command lies between both), bounds every velocity tried."""
        config = self.config
        gap = clear_gap(speed, self._dt_s, self._walk, self._limits.max_accel_mps2)
        return max(config.stop_distance_m + gap, config.slow_distance_m)  # type: ignore[type-var,operator]

    def _constraint(
        self, key: str, human: Entity, age_ms: int, slipped: bool, clear_m: float
    ) -> Constraint | None:
        """The limit ``human`` (a human, or an echo kept as one) sets; ``key`` names it;
        ``slipped``: its margin grows by the slip counted since it was taken. None: it
        is farther than ``clear_m`` (:meth:`_clear_m`) and under no protective stop."""
        config = self.config
        anchor = self._anchors[key]
        x, y = estimate(anchor, self._reckoning.pose)
        distance = hypot(x, y)
        echo = type(human) is Obstacle
        # an echo a working ring keeps while it misses the body: as long as it may keep it
        walk_ms = self._echo_walk_ms if echo and not slipped else config.max_data_age_ms
        seen_ms = min(age_ms + self._tick_ms, walk_ms)  # type: ignore[type-var]
        margin = config.sensing_error_m + config.human_speed_mps * max(seen_ms, 0) / 1000
        if slipped:  # the base may have slipped since: the reading placed that far off
            drift = self._reckoning.drift(anchor.since)
            margin += drift.distance_m + distance * min(drift.heading_rad, math.pi)
        surface = distance - config.robot_radius_m - config.human_radius_m - margin
        # a merging ring's echo: what made it lies on an arc (the ideal ring's: a point)
        arc = self._echoes.arc_m(human) if echo else 0.0
        if arc:  # its disc covers the arc; its distance is the arc's, less :meth:`_across`
            nearest = self._across(anchor, distance, arc) + surface - distance
            surface = max(surface - arc, nearest)
            margin += arc  # (the cone of that disc points away from every point of the arc)
        held = self._held
        if surface <= config.stop_distance_m:
            held[key] = None
        elif key in held and surface >= self._release_m:
            del held[key]
        elif surface >= clear_m:  # (release < slow <= clear_m) nothing it asks can fail
            return None
        if distance > 0:
            u_x, u_y = x / distance, y / distance
        else:
            u_x, u_y = 1.0, 0.0
        a, walk = self._limits.max_accel_mps2, self._walk
        sin_disc = 1.0 if margin >= distance else margin / distance
        reach = a * distance
        if key in held:
            return fields(
                Constraint, (key, surface, u_x, u_y, 0.0, sin_disc, _STOP, walk, reach, 0.0, 0.0)
            )
        # a tick at c, braking at a, and the human walking on meanwhile (the cap then falls
        # no faster than the base brakes): separation.braking_cap
        lead = a * self._dt_s + walk
        room = 2 * a * max(surface - config.stop_distance_m, 0.0)
        cap = braking_cap(lead, room, walk)
        if surface < config.slow_distance_m:
            cap = min(cap, config.slow_speed_mps)
        return fields(
            Constraint, (key, surface, u_x, u_y, cap, sin_disc, _SLOW, walk, reach, lead, room)
        )

    def _across(self, anchor: Anchor, distance: float, arc: float) -> float:
        """How near an echo's arc (``arc`` its chord, its centre ``distance`` away) lies to
        the robot, less what a drive may close on a point of it by moving across the line to
        its centre: the constraint bounds the closing part along that line, and a point of
        the arc lies at most ``asin(arc / distance)`` off it, so a drive closes on it by at
        most its way (a tick at the top speed, then braking) times that sine more
        (docs/actuator-and-joystick.md; the actuator caps every request at the top speed)."""
        x, y, _ = self._reckoning.pose
        top = max(self._limits.max_speed_mps, self._reckoning.speed)
        way = stopping_way(top, self._dt_s, self._limits.max_accel_mps2)
        sine = arc / distance if distance > arc else 1.0
        return self._echoes.off_arc(anchor, x, y) - way * sine

    def _anchor(self, key: str, human: Entity, now_ms: int) -> None:
        """Place a new reading in the odometry frame, with the pose the robot had when it
        was taken (looked for every tick, so that a reading is placed while that pose is
        kept), and no later than ``now_ms``, when it came, its centre where
        ``EchoSorter.centre_m`` places it (an echo of a ring of surfaces: beyond its range)."""
        stamp_ms = human.positionchangetime
        rho = self._echoes.centre_m(human)
        at_ms = min(stamp_ms, now_ms)
        since = self._reckoning.placed(at_ms)
        px, py, ptheta = since.pose
        bearing = ptheta + human.positiontheta
        x, y = px + rho * cos(bearing), py + rho * sin(bearing)
        self._anchors[key] = fields(Anchor, (stamp_ms, at_ms, x, y, since))


def _online(
    sensors: Sequence[Camera | Sonar],
    klass: str,
    heard: Mapping[tuple[str, str], int],
    since_ms: int,
) -> list[int]:
    """When each of ``sensors`` that says it is on was last heard from, if at ``since_ms``
    or later (one heard from before, or never, is offline: its link is dead), ms."""
    times = [heard.get((klass, s.id), _NEVER) for s in sensors if s.isonline]
    return [at_ms for at_ms in times if at_ms >= since_ms]


def _passed_over(since_ms: float | None, reported_ms: float, now_ms: int, after_ms: int) -> bool:
    """Whether the ring went on without a body last reported at ``reported_ms``: every
    sonar has scanned since (``since_ms``; None: a ring is down, or may hide it) and
    ``after_ms`` have passed."""
    return since_ms is not None and since_ms > reported_ms and now_ms - reported_ms > after_ms


def _late(heard_ms: list[int], now_ms: int, max_age_ms: int) -> bool:
    """Whether the oldest of ``heard_ms`` was heard more than three quarters of
    ``max_age_ms`` ago (a status late: its link may be dying)."""
    return 4 * (now_ms - min(heard_ms)) > 3 * max_age_ms
