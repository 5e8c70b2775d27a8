"""The sonar ring's echoes, for the safety supervisor (:mod:`~pipeline.act.safety`):
which of them are bodies of their own, and which a human the camera tracks.

The ring reports bodies as anonymous echoes (obstacles that are not fixed); the supervisor
keeps each at a human's distances, unless a fresh reading of a tracked human explains it:
the echo lies in that human's gate (closer than both readings' errors and the walk
between their times, never farther than ``human_radius_m``), and then the camera decides.
What else must hold depends on the ring (``sonar_beam_rad``):

- a ring whose sonars merge what their beam holds (``sonar_beam_rad`` > 0; every real
  ring): a sonar gives a range, not a bearing, so an echo is an arc: what made it lies at
  its range within half a beam of its bearing (its beam's axis), on a body's surface or at
  its centre (``sonar_reports_surface``: on its surface, below). The supervisor grows the
  echo's disc to cover the arc (:meth:`EchoSorter.arc_m`) and takes its distance from the
  arc itself (:meth:`EchoSorter.off_arc`), and a human's
  gate is measured to the arc, a body's radius wider (capped at two radii, not one): a
  gate is only a necessary condition for an echo to be that human's, and what makes
  dropping one sound is what follows. A child beside the one the camera sees, in the same
  beam, makes no echo of their own. An echo is taken for a tracked human only where the
  camera's frame that placed them saw all the beam that made it (the coverage rule): its
  bearing, in that frame, within the camera's half view less half a beam (the beam about
  its axis), the angle the echo's body subtends at its range (its disc may only reach into
  the beam) and the angle of the robot's move and a walk between both readings at that
  range; and the body that made it within the camera's range (``camera_range_m``: the
  camera reports a person only when their centre is in it), as far as it may have stood
  from where the robot was at that frame: the nearest body in the beam, its surface at the
  echo's range ``rho``, has its centre within ``rho`` and a body (``human_radius_m`` and
  ``sensing_error_m``) of where the ring took the echo, and that robot and that body may
  have moved apart by the robot's move and a walk between both readings (the reckoning's
  slip too, where it may have slipped, since the earlier reading: the move between them is
  reckoned; it widens the angle as the move does): ``rho + body + moved + walked <=
  camera_range_m``. A camera that may miss a child for ``camera_miss_ms`` must have
  framed, and seen all of the beam so, on every frame for that long before (the robot's
  path and largest turn then, and a walk that long, count as the move does).
  A child beyond the range, behind or beside the tracked one in the same beam, is never
  reported: without this their echo was dropped and the robot closed on them. A body the
  ring hides reaches no beam but those of nearer bodies: when the echoes of all of them
  are dropped, all their beams lay in the view, so its centre did, and the camera tracks
  it while its centre is within range (beyond it, it is hidden as below). Anywhere else
  every echo is kept. One body across two beams makes two echoes in one gate: both are
  that child.
- a ring that reports every body apart (0: the simulator's ideal ring): an echo is a
  tracked human's only when it is the one echo in that human's gate (two there are two
  bodies: one may be a child beside them, outside the camera's view, ``make soak
  SEED=35``); an echo alone in one human's gate is dropped even when another human's gate
  holds two (that human's own echo is then missing).

A ring that reports surfaces (``sonar_reports_surface``): the nearest surface in the beam
at range ``rho`` is the nearest point of a body's disc (radius ``r' <= human_radius_m``)
where that point lies in the beam; the disc meets no point of the beam nearer than ``rho``,
so it is tangent there to the circle of radius ``rho`` about where the robot's centre was,
its normal pointing at that centre, and its centre lies on the same ray, ``rho + r'`` out.
A smaller body tangent at the same point lies inside the disc of radius ``human_radius_m``
tangent there, whose centre is ``rho + human_radius_m`` out: the echo's centre is placed
there (:attr:`EchoSorter.beyond_m`), at the same bearing, and its arc is that of the
centres, its chord ``2 (rho + r) sin(beam / 4)``. It is a disc, not the point heard: a robot
moving across the ray comes nearer a disc tangent at a point than to that point. A body
whose disc only reaches into the beam (its nearest point in another beam) is heard where
the beam's edge enters it, its centre beyond that edge, off this arc (up to ``r sqrt 2``
from its end; ``r`` from a ring of centres' arc); the beam holding its nearest point may
hear a nearer body instead. It is bounded all the same, point by point, not by its centre:
each point ``X`` of any body lies in some beam, whose range ``rho <= |X|`` (the nearest
surface in it); the echo's arc holds ``Y``, at ``X``'s bearing, ``|Y| = rho + beyond_m``.
If ``|X| <= |Y| + r``, ``|X - Y| <= r`` (``|X| >= rho >= |Y| - r``), so from the robot at
``P`` ``|P - X| >= |P - Y| - r >= off_arc(P) - r``; farther, ``X`` lies on ``Y``'s ray
beyond it and ``|P - X| >= |P - Y|`` while ``P`` lies within ``|Y|`` of where the robot
was at the scan (a scan every 200 ms). The supervisor's distance (the arc's less a body,
or the disc's less its chord, ``|P - M| - chord <= |P - Y|``, ``M`` the arc's point on the
axis) is then never more than the robot's from any body in the beam beyond the range: a
child whose only echo clips their edge, behind a nearer body, too
(``tests/pipeline/act/test_act_safety_masked.py``). What makes an echo a tracked human's is
unchanged: its gate and the coverage rule take the surface's range,
``rho`` (the centre within a body of it; an edge's centre out of the beam by at most the
angle a body subtends at ``rho``).

No ring reports a body hidden behind nearer ones in every beam it reaches, and no echo
logic finds it (docs/actuator-and-joystick.md). No clock, no IO.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from math import asin, atan2, cos, hypot, remainder, sin, sqrt
from typing import NamedTuple

from oimi.pipeline.act.looking import SensorWatch
from oimi.pipeline.act.reckoning import DeadReckoning, Placed
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.messages import Camera, Entity, Obstacle, WorldMap


def arc_chord(rho: float, beam_rad: float) -> float:
    """The chord of half a beam ``beam_rad`` wide at ``rho``, ``2 rho sin(beam / 4)``: no
    point at that range within half a beam of the axis lies farther from the axis's point
    (0 for the ideal ring's beam, 0)."""
    return 2 * rho * sin(min(beam_rad, math.tau) / 4)


class Anchor(NamedTuple):
    """A reading placed in the odometry frame."""

    stamp_ms: int
    """Its ``positionchangetime`` (a new one is a new reading)."""
    at_ms: int
    """When it was taken: its stamp, but no later than it came (a sensor whose clock is
    ahead, frozen since, repeats a reading that would otherwise look fresh once the
    session's clock reached its stamp)."""
    x: float
    y: float
    since: Placed
    """The reckoning then (its drift since widens the margin while a sonar is down)."""


def estimate(anchor: Anchor, pose: tuple[float, float, float]) -> tuple[float, float]:
    """A reading's position in the body frame of a robot at ``pose`` (odometry frame)."""
    x, y, theta = pose
    dx, dy = anchor.x - x, anchor.y - y
    cos_t, sin_t = cos(theta), sin(theta)
    return (cos_t * dx + sin_t * dy, -sin_t * dx + cos_t * dy)


Kept = tuple[str, Entity, int]
"""An echo kept: its key, its reading and its age, ms."""


class _Keys(dict[str, str]):
    """An echo's key, ``Obstacle/<id>``, by its obstacle id: made when first asked for
    (an item read, compiled, where ``dict.get`` is a method call)."""

    def __missing__(self, ident: str) -> str:
        key = self[ident] = f"Obstacle/{ident}"
        return key


class EchoSorter:
    """Names the map's echoes and tells which of them a tracked human explains."""

    def __init__(
        self, config: SafetyConfig, reckoning: DeadReckoning, cameras: SensorWatch
    ) -> None:
        self._config = config
        """The supervisor's configuration (filled)."""
        self._reckoning = reckoning
        self._cameras = cameras
        """Since when each camera has framed (``camera_miss_ms``: the coverage rule's)."""
        self._keys = _Keys()
        """An echo's key by its obstacle id (made once)."""
        self._beam_rad: float = config.sonar_beam_rad  # type: ignore[assignment]  # filled
        """One sonar's beam (0: the ring reports every body apart)."""
        self._half_view: float = config.camera_fov_rad / 2  # type: ignore[operator]  # filled
        self._body_m: float = config.human_radius_m + config.sensing_error_m  # type: ignore[operator]
        """How far a body's edge may lie from the centre a reading gives."""
        surface = config.sonar_reports_surface and self._beam_rad > 0.0
        self.beyond_m: float = config.human_radius_m if surface else 0.0  # type: ignore[assignment]  # filled
        """How far beyond its range an echo's centre is placed: ``human_radius_m`` where the
        ring reports surfaces (the module's docstring), else 0 (its range may be a centre's;
        the ideal ring's is)."""
        self._arc_per_m = arc_chord(1.0, self._beam_rad)
        """An echo's arc's chord per metre of its range (:meth:`arc_m`)."""
        self._miss_ms: int = config.camera_miss_ms  # type: ignore[assignment]  # filled
        self._miss_walk_m: float = config.human_speed_mps * self._miss_ms / 1000  # type: ignore[operator]  # filled
        """How far a child may walk while the camera's frames all miss them."""
        self._reach_m: float = config.camera_range_m - self._body_m  # type: ignore[operator]  # filled
        """How far from the robot, at the camera's frame, an echo's range may lie (with the
        robot's move and a walk between both readings) for the camera to have reported the
        body that made it: its range less a body (:meth:`_covers`)."""

    def echoes(self, world_map: WorldMap) -> list[tuple[str, Entity]]:
        """The obstacles that are not fixed and have a reading, named ``Obstacle/<id>``
        (their anchors and holds are kept apart from the humans')."""
        keys = self._keys
        return [
            (keys[obstacle.id], obstacle)
            for obstacle in world_map.obstacles
            if not obstacle.isfixed and obstacle.poses
        ]

    def unexplained(
        self,
        kept: list[Kept],
        seen: list[Anchor],
        anchors: dict[str, Anchor],
        slipped: bool,
        framing: Sequence[Camera] = (),
    ) -> list[Kept]:
        """The kept echoes that are not a human the map tracks (``seen``: the fresh
        humans' anchors; ``anchors``: every reading's, by key; ``slipped``: the reckoning
        may have slipped since, a ring down; ``framing``: the cameras that frame at this
        tick): the module's docstring."""
        if not seen:
            return kept
        merging = self._beam_rad > 0.0
        since_ms = self._cameras.began_ms(framing) if merging else -math.inf
        near: list[list[int]] = [[] for _ in seen]  # per tracked human: the echoes it may be
        for i, (key, _, _) in enumerate(kept):
            echo = anchors[key]
            for j in self._near(echo, seen, slipped):
                if not merging or self._covers(echo, seen[j], slipped, since_ms):
                    near[j].append(i)
        if merging:
            explained = {i for echoes in near for i in echoes}
        else:
            explained = {echoes[0] for echoes in near if len(echoes) == 1}
        return [echo for i, echo in enumerate(kept) if i not in explained]

    def _near(self, echo: Anchor, seen: list[Anchor], slipped: bool) -> list[int]:
        """The tracked humans (indices in ``seen``) whose reading an echo may be: nearer than
        both readings' errors and the walk between their times, at most ``human_radius_m``
        (``slipped``: less the drift since the echo, placed that far off). On a merging ring
        the echo is an arc (:meth:`arc_m`) on the body's surface: the human's centre is
        measured to the arc at the surface's range (the echo's own less :attr:`beyond_m`),
        and may lie a body's radius more from it."""
        config = self._config
        _, at_ms, x, y, since = echo
        radius: float = config.human_radius_m  # type: ignore[assignment]  # filled
        surface = radius if self._beam_rad > 0.0 else 0.0  # the echo's body beyond it
        largest = radius + surface
        if slipped:
            drift = self._reckoning.drift(since)
            e_x, e_y = estimate(echo, self._reckoning.pose)
            largest -= drift.distance_m + hypot(e_x, e_y) * min(drift.heading_rad, math.pi)
        found = []
        for j, (_, human_ms, hx, hy, _) in enumerate(seen):
            walked = config.human_speed_mps * abs(at_ms - human_ms) / 1000  # type: ignore[operator]
            gate = min(2 * config.sensing_error_m + walked + surface, largest)  # type: ignore[operator]
            off = self.off_arc(echo, hx, hy, self.beyond_m) if surface else hypot(x - hx, y - hy)
            if off <= gate:
                found.append(j)
        return found

    def off_arc(self, echo: Anchor, x: float, y: float, nearer: float = 0.0) -> float:
        """How far (x, y) (odometry frame: a human's centre, or the robot's) lies from the
        echo's arc: the points at its range (less ``nearer``) within half a beam of its
        bearing, from where the robot was when it was taken."""
        p_x, p_y, _ = echo.since.pose
        e_x, e_y, d_x, d_y = echo.x - p_x, echo.y - p_y, x - p_x, y - p_y
        rho, far = max(hypot(e_x, e_y) - nearer, 0.0), hypot(d_x, d_y)
        apart = abs(remainder(atan2(d_y, d_x) - atan2(e_y, e_x), math.tau))
        beyond = max(apart - self._beam_rad / 2, 0.0)  # from the arc's nearer end
        return sqrt(max(rho * rho + far * far - 2 * rho * far * cos(beyond), 0.0))

    def centre_m(self, reading: Entity) -> float:
        """How far from the robot (where it was then) a reading places a body's centre: its
        range, and :attr:`beyond_m` more for an echo (a ring of surfaces' heard a surface)."""
        return reading.positionrho + (self.beyond_m if type(reading) is Obstacle else 0.0)

    def arc_m(self, reading: Entity) -> float:
        """How far what made a reading may lie from where it places it, beyond its errors: 0
        for a human (the camera gives a bearing); for an echo of a merging ring, the chord
        of half a beam at its range, ``2 rho sin(beam / 4)`` (a sonar gives a range, not a
        bearing: whatever it heard lies at that range within half a beam of its axis, where
        a driver places it, and no farther from that point than this). The supervisor grows
        the echo's margin by it, its centre kept at the range (:attr:`beyond_m` farther on a
        ring of surfaces, the chord taken there): docs/actuator-and-joystick.md."""
        if self._beam_rad == 0.0 or not isinstance(reading, Obstacle):
            return 0.0
        return (max(reading.positionrho, 0.0) + self.beyond_m) * self._arc_per_m

    def _covers(self, echo: Anchor, human: Anchor, slipped: bool, since_ms: float) -> bool:
        """Whether the camera's frame that placed ``human`` saw all that the beam which
        made ``echo`` may hold (the coverage rule: the module's docstring; ``slipped``:
        the heading and distance the reckoning may have slipped since the earlier of both
        readings count against it, as the move does: the move between them is reckoned).
        In the view: its bearing in that frame, within the camera's half view less half a
        beam, the body's angle and the move's, walk's and slip's. In range: what made
        the echo is the nearest body in its beam, its surface at the echo's range ``rho``
        (the echo's own less :attr:`beyond_m`; a driver may give a centre: nearer still),
        so its centre lay within ``rho + body`` (``human_radius_m + sensing_error_m``) of
        the robot then, and within ``moved`` (the robot between both readings) and
        ``walked`` (a walk between their times) more of the robot at the frame (and the
        slip): ``rho + body + moved + walked (+ slip) <= camera_range_m``. A camera whose
        frames may all miss a child for ``camera_miss_ms`` must have seen it so on every
        frame for that long before: framing since (``since_ms``), the robot's path and
        largest turn then, and a walk that long, count as the move does (``since_ms``:
        since when the cameras have framed without a break), and with ``slipped`` the slip
        is counted from the first of those frames where it is the earlier."""
        e_x, e_y, _ = echo.since.pose  # the robot when the ring took the echo
        h_x, h_y, h_theta = human.since.pose  # and when the camera took its frame
        d_x, d_y = echo.x - e_x, echo.y - e_y
        rho = hypot(d_x, d_y) - self.beyond_m  # the surface's range
        body = self._body_m
        if rho <= body:
            return False  # a body's disc reaches all round the robot
        moved = hypot(e_x - h_x, e_y - h_y)
        walked = self._config.human_speed_mps * abs(echo.at_ms - human.at_ms) / 1000  # type: ignore[operator]
        apart = moved + walked  # how far the body may lie from where the frame looked
        turned = 0.0
        start_ms = human.at_ms - self._miss_ms  # (the frames that must all have looked)
        if slipped:  # the moves may have slipped: since the earlier reading, or those frames
            earlier = echo.since if echo.since.at_ms <= human.since.at_ms else human.since
            if start_ms < earlier.at_ms:
                earlier = self._reckoning.placed(start_ms)
            drift = self._reckoning.drift(earlier)
            apart += drift.distance_m
            turned = min(drift.heading_rad, math.pi)
        if self._miss_ms:  # (a frame's silence alone is weak: every frame before too)
            swept = self._reckoning.swept(start_ms, human.at_ms)
            if swept is None or since_ms > start_ms:
                return False  # (not looking all that while, or its moves not kept)
            apart += swept.distance_m + self._miss_walk_m
            turned += swept.heading_rad
        if rho + apart > self._reach_m:  # (its centre from the frame, less a body)
            return False  # it may have stood beyond the camera's range: never reported
        spread = self._beam_rad / 2 + asin(body / rho)  # its beam, about its axis
        spread += asin(min(1.0, apart / rho)) + turned
        bearing = atan2(d_y, d_x) - h_theta
        off = abs(remainder(bearing, math.tau))  # from the camera's heading, in that frame
        return off + spread <= self._half_view
