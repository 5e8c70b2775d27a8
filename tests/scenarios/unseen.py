"""Which children the safety property (``test_safety_property.py``) may skip as unknown to
the supervisor, and which of those a rule of the supervisor still claims to protect.

A child no sensor can see (``hidden``) or none has reported (``session_record.reports``)
is beyond the supervisor's separation rules, but not beyond its narrowed view
(docs/actuator-and-joystick.md, "Only where a sensor looks"): while a sonar of the ring
is down, linear motion stays inside the camera's view, narrowed so that a child centred
outside the view beyond the slow zone stays out of the stop zone. :class:`NarrowedView`
says when that claim covers a child, so that the property does not skip them."""

from __future__ import annotations

import math
from collections.abc import Sequence

from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.events import WorldState
from oimi.scenarios.simulation.bodies import wrap_angle
from oimi.scenarios.simulation.sensors import beam_echoes

HUMAN_RADIUS_M = 0.25
"""The humans' radius (the supervisor's ``human_radius_m``)."""
RING_M = 3.0
"""The ring's range (the scenarios' default)."""
TURN_RAD = 0.002
"""The most the heading may change (``/world/state`` keeps milliradians) while a claim
holds: a turn may bring a body the drive passed to an edge of the view."""
SKEW_RAD = 0.005
"""How far outside the narrowed view the recorded velocity may point when a claim starts
(``/world/state`` cuts speeds to mm/s; the sensing error's slack covers it)."""
STILL_MPS = 0.002
"""A recorded speed this low has no direction to speak of (it points anywhere)."""


def hidden(state: WorldState, safety: SafetyConfig, beams: int) -> set[str]:
    """The humans no sensor can see now (on the truth): the camera's (``camera_fov_rad`` and
    ``camera_range_m`` of ``safety``, filled: its scenario's) reports a centre within its
    range and view; a ring of ``beams`` sonars reports the nearest surface in each beam (the
    simulator's), so it hides a body behind nearer ones in every beam its disc reaches; the
    ideal ring (0) reports every surface within its range."""
    robot = state.robot
    pose = (robot.x_m, robot.y_m, robot.theta_rad)
    half_view, reach = safety.camera_fov_rad / 2, safety.camera_range_m  # type: ignore[operator]
    if beams:
        bodies = [(h.id, h.x_m, h.y_m, HUMAN_RADIUS_M, False) for h in state.humans]
        echoed = {name.split(".")[0] for name, _, _ in beam_echoes(bodies, pose, beams, RING_M)}
    else:
        echoed = {
            h.id
            for h in state.humans
            if math.hypot(h.x_m - robot.x_m, h.y_m - robot.y_m) - HUMAN_RADIUS_M <= RING_M
        }
    unseen = set()
    for h in state.humans:
        dx, dy = h.x_m - robot.x_m, h.y_m - robot.y_m
        bearing = abs(wrap_angle(math.atan2(dy, dx) - robot.theta_rad))
        if h.id not in echoed and (bearing > half_view or math.hypot(dx, dy) > reach):
            unseen.add(h.id)
    return unseen


class NarrowedView:
    """The children the narrowed view claims to keep out of the stop zone, tick by tick.

    A claim on a child starts at a tick ``a`` at which (on the truth) a sonar of the ring
    is surely down (``session_record.ring_down``), the robot's velocity points inside the
    narrowed view (or it stands), and the child is centred outside the camera's view
    (``camera_fov_rad``) farther than ``R + r + e + slow_distance_m`` from the robot's
    centre, and stood there at the tick before. It holds while the ring stays down, the
    robot does not turn (nor is pushed) and the child stands. Then every command points
    inside the narrowed view, so every velocity of the base does (ramped from one inside
    to one inside), and the robot stays inside the narrowed cone from where it was at
    ``a``, which keeps its centre ``R + r + e + stop_distance_m`` or more from the child's:
    outside the stop zone (the sensing error ``e`` covers this check's tolerances).

    The limits the supervisor states (docs/actuator-and-joystick.md) are left out by
    construction: a child within the slow zone beside the robot when the ring goes down
    (or when the base turns onto the view), a turn, a ring counted on while silent (a claim
    starts once it is known to be down), a base still moving outside the view (once it
    moves inside); and so is a child walking, who may walk into the view's cone."""

    def __init__(self, safety: SafetyConfig, down: Sequence[bool]) -> None:
        safety = safety.filled()
        radii = safety.robot_radius_m + safety.human_radius_m + safety.sensing_error_m  # type: ignore[operator]
        assert safety.camera_fov_rad is not None
        self.half_view = safety.camera_fov_rad / 2
        self.beyond_m = radii + safety.slow_distance_m
        self.looking_rad = self.half_view - math.asin(
            (radii + safety.stop_distance_m) / self.beyond_m
        )
        """The narrowed view's half angle (docs/actuator-and-joystick.md), rad."""
        self._down = down
        self._heading: float | None = None
        """The robot's heading since the ring went down (None: it is up, or a camera sees
        all round: no claim)."""
        self._claims: dict[str, tuple[float, float]] = {}
        """The children claimed, each where they stood when the claim started."""
        self._where: dict[str, tuple[float, float]] = {}
        """Where each child was at the tick before (one who moved since is walking)."""

    def update(self, state: WorldState) -> None:
        """Start, keep or end the claims at ``state``'s tick."""
        robot = state.robot
        heading = self._heading
        if not self._down[state.tick] or self.half_view >= math.pi or state.contacts:
            self._heading, self._claims = None, {}  # (a push moves the robot off its drive)
            self._where = {h.id: (h.x_m, h.y_m) for h in state.humans}
            return
        if heading is None or abs(wrap_angle(robot.theta_rad - heading)) > TURN_RAD:
            self._heading, self._claims = robot.theta_rad, {}
        inside = math.hypot(robot.vx_mps, robot.vy_mps) <= STILL_MPS or (
            self.looking_rad >= 0.0
            and abs(wrap_angle(math.atan2(robot.vy_mps, robot.vx_mps) - robot.theta_rad))
            <= self.looking_rad + SKEW_RAD
        )
        for h in state.humans:
            here, before = (h.x_m, h.y_m), self._where.get(h.id)
            self._where[h.id] = here
            if here != before:  # walking (or just come): not claimed
                self._claims.pop(h.id, None)
                continue
            if h.id in self._claims:
                continue
            dx, dy = h.x_m - robot.x_m, h.y_m - robot.y_m
            outside = abs(wrap_angle(math.atan2(dy, dx) - robot.theta_rad)) > self.half_view
            if inside and outside and math.hypot(dx, dy) > self.beyond_m:
                self._claims[h.id] = here

    def claims(self, name: str) -> bool:
        """Whether the narrowed view claims to keep ``name`` out of the stop zone now."""
        return name in self._claims
