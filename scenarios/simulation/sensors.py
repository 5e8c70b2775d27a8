"""Simulated sensors: the world turned into the thesis's MapUpdates (tables 4.1 and 4.2).

A front camera sees humans and objects within ``range_m`` and ``fov_rad``; a
sonar ring sees every body within ``sonar_range_m`` all around: the room's
obstacles (``isfixed``) and, as anonymous obstacles that are not fixed, the people
(``Obstacle/echo-N``, N the person's place in the scenario; a real ring cannot tell a
child from a chair, and the safety supervisor keeps its distance from such echoes,
behind the robot too). The ideal ring (``sonar_beams`` 0) reports every body apart, once,
at its centre. A ring of ``sonar_beams`` sonars, evenly spaced from straight ahead, is a
real one: a sonar gives a range, not a bearing. Each reports the distance from the robot's
centre to the nearest surface its beam reaches (the nearest point of each disc within its
beam's sector: a disc that only reaches in counts where it does), placed on the beam's
axis, up to half a beam from the body; within ``sonar_range_m``. Furniture is a point at
its centre, seen only by the sonar whose beam holds it (the supervisor never limits a
fixed body: all it does to the ring is hide what lies behind it there). Two people in one
beam make one echo, the nearer's; one whose disc reaches two beams, nearest in both, makes
two (the one in the beam holding their centre ``echo-N``, the other ``echo-N.sK``, K the
sonar's index); one behind nearer bodies in every beam they reach makes none (occlusion).
Each entity's pose is reported relative to the robot (``positionrho`` m from its centre,
``positiontheta`` rad from its heading, counter-clockwise, in (-pi, pi]), with
seeded gaussian noise and dropouts, at the sensor's rate; ``tracking`` follows an
entity while it stays in view; ``isfixed``, ``istarget``, ``category`` come once,
on first sight; the ring's ``scantime`` and the camera's ``frametime`` with every scan or
frame (their heartbeats: a frozen sensor repeats an old one). Sensor status comes at the
start and on faults; touches from touch events and from contacts; the robot's speed (its
mean velocity since the last report, from the odometer: how far the base went, blocked or
pushed too), battery and elapsed time every ``status_period_s``, and its speed every
``RING_DOWN_SPEED_MS`` while the ring is down.

Encoding decisions: ``poses`` use policy ``A`` (the map keeps the history),
everything else ``R``; scalar contents are bare text (``s_true``, ``640``,
``ball``), records are JSON objects with the tables' keys in the tables' order;
floats are rounded to 4 decimals so the JSON text is stable.
"""

from __future__ import annotations

import math
import random
from typing import Final

import msgspec
from oimi.pipeline.messages import MapUpdate, Policy
from oimi.scenarios.schema import (
    FaultEvent,
    FaultMode,
    Scenario,
    SensorKind,
    SensorSpec,
    TouchEvent,
)
from oimi.scenarios.simulation.bodies import rounded, wrap_angle
from oimi.scenarios.simulation.world import World

DECIMALS: Final = 4
TRUE: Final = "s_true"
FALSE: Final = "s_false"
MAX_CATCH_UP: Final = 1000
"""Most periods a schedule steps over in one tick (a 1 ms period in a 1 s tick)."""
RING_DOWN_SPEED_MS: Final = 100
"""How often the robot reports its speed while its ring is down (offline, frozen or
silent), ms: the safety supervisor then counts a push over the time no report covers, and
a report a second would leave it unsure where the robot is by a walk's second."""


_REPLACE: Final = Policy.R
_APPEND: Final = Policy.A
_ONLINE: Final = FaultMode.ONLINE
"""Looked up once: an enum's member read through its class takes ``EnumType``'s slow
``__getattr__`` path (every reading names a policy per entity)."""

_Update = tuple[str, str, Policy, str]
"""A MapUpdate before its sequence number: ``(objectid, attributename, policy, jsonmsg)``
(a plain tuple: sensors make and drop several per person at every reading)."""


class Schedule:
    """Something due every ``period_ms`` from 0, at most once a tick.

    The scenario's ranges keep periods positive and finite; this refuses any other
    and never steps more than ``MAX_CATCH_UP`` periods, so no period can hang a tick.
    """

    def __init__(self, period_ms: float):
        if not (math.isfinite(period_ms) and period_ms > 0):
            raise ValueError(f"a sensor period must be positive and finite, got {period_ms!r} ms")
        self.period_ms = period_ms
        self.next_ms = 0.0

    def due(self, time_ms: int) -> bool:
        """Whether it is due at ``time_ms``; if so, the schedule moves past it."""
        if time_ms < self.next_ms:
            return False
        for _ in range(MAX_CATCH_UP):
            self.next_ms += self.period_ms
            if self.next_ms > time_ms:
                return True
        self.next_ms = math.nextafter(float(time_ms), math.inf)  # due again next tick
        return True


class _Sensor(Schedule):
    """Mode, schedule, tracks and last reading of one sensor."""

    def __init__(self, objectid: str, heartbeat: str, period_ms: float):
        super().__init__(period_ms)
        self.objectid = objectid
        """``Camera/<id>`` or ``Sonar/<id>``."""
        self.heartbeat = heartbeat
        """The attribute that says when a reading was taken (``frametime``, ``scantime``)."""
        self.mode = FaultMode.ONLINE
        self.tracks: dict[str, int] = {}
        """objectid -> appearance time (ms), in order of appearance."""
        self.last: list[_Update] = []


class Sensors:
    """Produces each tick's MapUpdates from the world; ``seq`` counts from 1 in a session."""

    def __init__(self, config: SensorSpec, scenario: Scenario, rng: random.Random):
        self.config = config
        self.scenario = scenario
        self.rng = rng
        self.camera = _Sensor(f"Camera/{config.camera_id}", "frametime", _period_ms(config.rate_hz))
        self.sonar = _Sensor(
            f"Sonar/{config.sonar_id}", "scantime", _period_ms(config.sonar_scan_hz)
        )
        self._status = Schedule(config.status_period_s * 1000)
        self._odometer: tuple[int, tuple[float, float, float]] = (0, (0.0, 0.0, 0.0))
        """When the robot's speed was last reported, ms, and the odometer then."""
        self._seq = 0
        self._started = False
        self._pending: list[_Update] = []
        self._led: tuple[tuple[float, float, float], int] = ((0.0, 0.0, 0.0), 0)
        """The LED colour shown and since when (ms), for the robot's history of actions."""
        self._audio: tuple[str, int] = ("", 0)
        """The track playing and since when (ms)."""
        self._seen: set[str] = set()
        """objectids whose once-only attributes were sent (membership only, never iterated)."""
        self._furniture = [("Obstacle", o.id, o.x_m, o.y_m) for o in scenario.world.obstacles]
        """The bodies the sonar sees besides people (furniture does not move)."""
        self._fixed = furniture = frozenset(o.id for o in scenario.world.obstacles)
        """The ids of the obstacles that are fixed (every other obstacle is an echo)."""
        self._echoes: dict[str, str] = {}
        """Person id -> the id of the sonar's echo of them (``echo-N``: unlike any obstacle's,
        and no obstacle's begins as one of a beam's, ``echo-N.sK``, does)."""
        for n, human in enumerate(scenario.humans):
            ident = f"echo-{n}"
            while ident in furniture or any(f.startswith(f"{ident}.s") for f in furniture):
                ident += "_"
            self._echoes[human.id] = ident
        self._radii = {human.id: human.radius_m for human in scenario.humans}
        """Person id -> their radius, m (a beam reaches a person's disc)."""

    # --------------------------------------------------------------- inputs

    def fault(self, event: FaultEvent) -> None:
        """Switch a sensor's mode; offline and online are reported as ``isonline``, a
        silent sensor says nothing."""
        sensor = self.camera if event.sensor is SensorKind.CAMERA else self.sonar
        sensor.mode = event.mode
        if event.mode is FaultMode.FROZEN:
            return
        if event.mode is not FaultMode.ONLINE:
            sensor.tracks.clear()  # no reading until it comes back: people appear again
        if event.mode is FaultMode.SILENT:
            return  # its link is dead: nothing said
        self._pending.append(self._status_of(sensor))

    def touch(self, event: TouchEvent, *, time_ms: int) -> None:
        """A scheduled touch, reported at the next sample."""
        self._pending.append(_touch(str(event.touchtype), event.duration_ms, time_ms))

    # -------------------------------------------------------------- sampling

    def sample(self, world: World, *, tick: int, time_ms: int) -> list[MapUpdate]:
        """This tick's updates, in a fixed order: status, pending, touches, actions performed
        (LED, audio), camera, sonar, robot."""
        updates: list[_Update] = []
        if not self._started:
            self._started = True
            updates.extend(self._startup(time_ms))
        updates.extend(self._pending)
        self._pending.clear()
        if world.last_report.tick == tick:
            for span in world.last_report.ended:
                updates.append(_touch(span.touchtype, span.duration_ms, span.startingtime_ms))
        updates.extend(self._actions(world, time_ms))
        camera, sonar = self.camera.due(time_ms), self.sonar.due(time_ms)
        if camera or sonar:
            pose = world.robot_pose()
            if camera:
                seen = [("Human", *h) for h in world.human_positions()]
                seen += [("Object", *o) for o in world.object_positions()]
                config = self.config
                updates.extend(
                    self._read(self.camera, seen, pose, time_ms, config.range_m, config.fov_rad)
                )
            if sonar:
                range_m = self.config.sonar_range_m
                people = world.human_positions()
                if self.config.sonar_beams:
                    bodies = self._beams(people, pose, range_m)
                else:
                    echoes = self._echoes
                    bodies = [*self._furniture]
                    bodies += [("Obstacle", echoes[h], x, y) for h, x, y in people]
                updates.extend(self._read(self.sonar, bodies, pose, time_ms, range_m, math.tau))
        if self._status.due(time_ms):
            updates.extend(self._robot_status(world, time_ms))
            updates.extend(self._sensor_status())
        elif self.sonar.mode is not _ONLINE and time_ms - self._odometer[0] >= RING_DOWN_SPEED_MS:
            updates.append(self._speed(world, time_ms))
        if not updates:
            return []
        first = self._seq + 1
        self._seq += len(updates)
        return [
            MapUpdate(objectid=target, attributename=name, policy=policy, jsonmsg=jsonmsg, seq=seq)
            for seq, (target, name, policy, jsonmsg) in enumerate(updates, first)
        ]

    def _startup(self, time_ms: int) -> list[_Update]:
        config = self.config
        camera, sonar = self.camera.objectid, self.sonar.objectid
        return [
            (camera, "isonline", _REPLACE, TRUE),
            (camera, "width", _REPLACE, str(config.camera_width_px)),
            (camera, "height", _REPLACE, str(config.camera_height_px)),
            (camera, "fps", _REPLACE, str(config.camera_fps)),
            (sonar, "isonline", _REPLACE, TRUE),
            (sonar, "scanfrequency", _REPLACE, str(config.sonar_scan_hz)),
            ("RobotStatus", "startingtime", _REPLACE, str(time_ms)),
        ]

    def _read(
        self,
        sensor: _Sensor,
        entities: list[tuple[str, str, float, float]],
        pose: tuple[float, float, float],
        time_ms: int,
        range_m: float,
        fov_rad: float,
    ) -> list[_Update]:
        """One reading of a sensor: what it sees, or its last reading when frozen."""
        if sensor.mode is not _ONLINE:  # offline or silent: nothing; frozen: the last again
            return list(sensor.last) if sensor.mode is FaultMode.FROZEN else []
        x, y, theta = pose
        half_fov, tracks, rng, config = fov_rad / 2, sensor.tracks, self.rng, self.config
        dropout, noise_rho, noise_theta = (
            config.dropout_probability,
            config.noise_rho_m,
            config.noise_theta_rad,
        )
        reading: list[_Update] = []
        in_view: set[str] = set()
        for cls, ident, ex, ey in entities:
            dx, dy = ex - x, ey - y
            rho = math.hypot(dx, dy)
            bearing = wrap_angle(math.atan2(dy, dx) - theta)
            if rho > range_m or abs(bearing) > half_fov:
                continue
            objectid = f"{cls}/{ident}"
            in_view.add(objectid)
            appeared = tracks.setdefault(objectid, time_ms)
            if dropout and rng.random() < dropout:
                continue
            if noise_rho:
                rho = max(0.0, rho + rng.gauss(0.0, noise_rho))
            if noise_theta:
                bearing = wrap_angle(bearing + rng.gauss(0.0, noise_theta))
            if objectid not in self._seen:
                self._seen.add(objectid)
                reading.extend(self._first_sight(cls, ident, objectid))
            reading.append(_pose(objectid, rho, bearing, time_ms))
            reading.append((objectid, "tracking", _REPLACE, _tracking(time_ms, appeared)))
        for objectid in list(tracks):
            if objectid not in in_view:
                del tracks[objectid]
        # its heartbeat: when this scan or frame was taken (a frozen sensor repeats it, old)
        reading.append((sensor.objectid, sensor.heartbeat, _REPLACE, str(time_ms)))
        sensor.last = reading
        return reading

    def _beams(
        self,
        people: list[tuple[str, float, float]],
        pose: tuple[float, float, float],
        range_m: float,
    ) -> list[tuple[str, str, float, float]]:
        """What a ring of ``sonar_beams`` sonars reports (:func:`beam_echoes`)."""
        bodies = [(o[1], o[2], o[3], 0.0, True) for o in self._furniture]
        echoes, radii = self._echoes, self._radii
        bodies += [(echoes[h], x, y, radii[h], False) for h, x, y in people]
        found = beam_echoes(bodies, pose, self.config.sonar_beams, range_m)
        return [("Obstacle", name, x, y) for name, x, y in found]

    def _first_sight(self, cls: str, ident: str, objectid: str) -> list[_Update]:
        if cls == "Obstacle":
            fixed = ident in self._fixed
            return [(objectid, "isfixed", _REPLACE, TRUE if fixed else FALSE)]
        if cls == "Object":
            spec = next(o for o in self.scenario.world.objects if o.id == ident)
            return [
                (objectid, "istarget", _REPLACE, TRUE if spec.istarget else FALSE),
                (objectid, "category", _REPLACE, spec.category),
            ]
        return []

    def _actions(self, world: World, time_ms: int) -> list[_Update]:
        """The robot's history of performed actions (thesis 4.1): an LED colour or a track,
        reported (policy A) when it ends, with when it started and how long it lasted."""
        colour, since = self._led
        if world.led == colour and world.audio == self._audio[0]:  # most ticks
            return []
        updates = []
        if world.led != colour:
            if any(colour):
                r, g, b = (round(c, DECIMALS) + 0.0 for c in colour)
                led = {
                    "r": r,
                    "g": g,
                    "b": b,
                    "frequency": 0,
                    "duration": time_ms - since,
                    "startingtime": since,
                }
                updates.append(("RobotStatus", "led", _APPEND, _json(led)))
            self._led = (world.led, time_ms)
        track, since = self._audio
        if world.audio != track:
            if track:
                audio = {"duration": time_ms - since, "startingtime": since, "trackpath": track}
                updates.append(("RobotStatus", "audioout", _APPEND, _json(audio)))
            self._audio = (world.audio, time_ms)
        return updates

    def _robot_status(self, world: World, time_ms: int) -> list[_Update]:
        battery_ms = max(0, round(self.scenario.robot.battery_s * 1000) - time_ms)
        return [
            self._speed(world, time_ms),
            ("RobotStatus", "batterytimeleft", _REPLACE, str(battery_ms)),
            ("RobotStatus", "elapsedtime", _REPLACE, str(time_ms)),
        ]

    def _speed(self, world: World, time_ms: int) -> _Update:
        """The robot's mean velocity since its last speed report (the odometer's reading)."""
        since_ms, (forward, left, turn) = self._odometer
        odometer = world.odometer
        lasted_s = (time_ms - since_ms) / 1000 or math.inf  # the first: nothing to average
        speed = {  # the mean velocity since the last report (the odometer's reading)
            "xspeed": round((odometer[0] - forward) / lasted_s, DECIMALS) + 0.0,
            "yspeed": round((odometer[1] - left) / lasted_s, DECIMALS) + 0.0,
            "thetaspeed": round((odometer[2] - turn) / lasted_s, DECIMALS) + 0.0,
            "duration": time_ms - since_ms,
            "startingtime": since_ms,
        }
        self._odometer = (time_ms, odometer)
        return ("RobotStatus", "speed", _REPLACE, _json(speed))

    def _sensor_status(self) -> list[_Update]:
        """Each sensor's ``isonline`` again, with the robot's status: a listener that missed
        the first report (a bridge joining late) learns it within a status period."""
        sensors = (self.camera, self.sonar)
        return [self._status_of(s) for s in sensors if s.mode is not FaultMode.SILENT]

    def _status_of(self, sensor: _Sensor) -> _Update:
        """A sensor's ``isonline`` as its mode says."""
        online = FALSE if sensor.mode is FaultMode.OFFLINE else TRUE
        return (sensor.objectid, "isonline", _REPLACE, online)


Body = tuple[str, float, float, float, bool]
"""A body the ring may report: its echo's id, centre (m, m), radius (m), whether fixed."""


def beam_echoes(
    bodies: list[Body], pose: tuple[float, float, float], beams: int, range_m: float
) -> list[tuple[str, float, float]]:
    """What a ring of ``beams`` sonars at ``pose`` reports of ``bodies`` (the module's
    docstring), as (id, x, y), in the sonars' order: each sonar's nearest surface within
    ``range_m`` (the earlier of ``bodies`` on a tie), placed on its beam's axis at that
    surface's distance from the robot's centre. A fixed body is a point at its centre,
    reported only by the sonar whose beam holds it; another is reported by every sonar its
    disc reaches, ``<id>.s<K>`` but in that one."""
    width = math.tau / beams
    x, y, theta = pose
    nearest: list[tuple[float, int, str] | None] = [None] * beams
    for order, (ident, bx, by, radius, fixed) in enumerate(bodies):
        dx, dy = bx - x, by - y
        rho = math.hypot(dx, dy)
        if rho - radius > range_m:
            continue  # its nearest surface is out of range in every beam
        bearing = math.atan2(dy, dx) - theta
        centre = math.floor(bearing / width + 0.5) % beams
        reach = math.asin(radius / rho) if rho > radius else math.pi
        spread = 0 if fixed else min(math.ceil(reach / width + 0.5), beams // 2)
        for k in sorted({(centre + j) % beams for j in range(-spread, spread + 1)}):
            outside = abs(wrap_angle(bearing - k * width)) - width / 2
            surface = in_sector(rho, min(outside, 0.0) if k == centre else outside, radius)
            if surface is None or surface > range_m:
                continue  # its disc does not reach into this beam (or only out of range)
            best = nearest[k]
            if best is None or (surface, order) < best[:2]:
                nearest[k] = (surface, order, ident if k == centre else f"{ident}.s{k}")
    found = []
    for k, best in enumerate(nearest):
        if best is not None:
            surface, _, name = best
            axis = theta + k * width
            found.append((name, x + surface * math.cos(axis), y + surface * math.sin(axis)))
    return found


def in_sector(rho: float, outside: float, radius: float) -> float | None:
    """The distance from a sonar's apex to the nearest point of a disc (centre ``rho`` m
    away, ``radius``) within its beam's sector, the disc's centre ``outside`` rad beyond
    the sector's nearer edge (none or less: within it); None: the disc does not reach in.
    Within, the disc's nearest point (``rho - radius``, none if the disc holds the apex);
    beyond, where the nearer edge enters the disc (the sector, at most half a turn wide,
    is convex: its point nearest the apex lies on that edge)."""
    if rho <= radius:
        return 0.0  # the disc holds the sonar's apex, the robot's centre
    if outside <= 0.0:
        return rho - radius
    if outside >= math.pi / 2:
        return None  # the edge points away from the disc's side: it reaches no point of it
    off = rho * math.sin(outside)  # the disc's centre from the edge's line
    if off > radius:
        return None
    return rho * math.cos(outside) - math.sqrt(radius * radius - off * off)


def _period_ms(rate_hz: float) -> float:
    """The period of a rate, ms (NaN for a rate that is not positive: refused by ``Schedule``)."""
    return 1000 / rate_hz if rate_hz > 0 else math.nan


def _pose(objectid: str, rho: float, theta: float, time_ms: int) -> _Update:
    content = {
        "positionrho": rounded(rho, DECIMALS) + 0.0,
        "positiontheta": rounded(theta, DECIMALS) + 0.0,
        "positionchangetime": time_ms,
    }
    return (objectid, "poses", _APPEND, _json(content))


def _tracking(time_ms: int, appeared_ms: int) -> str:
    """A track's record, ``{"permanencetime":..,"appearanceon":..}``: two integers, written
    as ``_json`` writes them (a dict encoded, then decoded, cost about twice as much)."""
    return f'{{"permanencetime":{time_ms - appeared_ms},"appearanceon":{appeared_ms}}}'


def _touch(touchtype: str, duration_ms: int, startingtime_ms: int) -> _Update:
    content = {"touchtype": touchtype, "duration": duration_ms, "startingtime": startingtime_ms}
    return ("RobotStatus", "touch", _APPEND, _json(content))


_ENCODER: Final = msgspec.json.Encoder()


def _json(content: dict[str, object]) -> str:
    return _ENCODER.encode(content).decode()
