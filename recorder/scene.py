"""The static scene a runner hands to the sinks so they can draw the arena."""

from __future__ import annotations

import msgspec


class ObstacleGeometry(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One fixed obstacle: a box (``width_m`` x ``height_m``) or, when ``radius_m > 0``, a disc."""

    id: str
    kind: str = ""
    """Free text (``table``, ``wall``...), shown as a label."""
    x_m: float
    """Centre, metres from the arena's lower-left corner."""
    y_m: float
    width_m: float = 0.0
    """Extent along x, m (boxes)."""
    height_m: float = 0.0
    """Extent along y, m (boxes; a plan-view size, not a vertical height)."""
    radius_m: float = 0.0
    """Radius, m (discs)."""
    angle_rad: float = 0.0
    """Rotation about the vertical axis, counter-clockwise (boxes)."""

    @property
    def is_disc(self) -> bool:
        return self.radius_m > 0.0


class SafetyZones(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """The safety supervisor's zones around a person, as surface-to-surface distances (m).

    Drawn by the Rerun sink as rings around each person at their radius plus each
    distance: the robot's body crossing a ring puts it in that zone.
    """

    stop_m: float = 0.1
    """Closer than this, the robot stops."""
    slow_m: float = 0.5
    """Closer than this, the robot slows down."""

    def acting(self, gap_m: float) -> str | None:
        """The zone a surface distance ``gap_m`` falls in: ``stop``, ``slow`` or None."""
        if gap_m <= self.stop_m:
            return "stop"
        if gap_m <= self.slow_m:
            return "slow"
        return None


class SceneGeometry(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """The arena ``[0, width_m] x [0, height_m]`` and its fixed obstacles, in drawing order."""

    width_m: float
    height_m: float
    obstacles: tuple[ObstacleGeometry, ...] = ()
    safety: SafetyZones = SafetyZones()
    """The safety supervisor's zones as the recorded session configured them."""
    door: tuple[tuple[float, float], tuple[float, float]] | None = None
    """The door people who leave walk out by, as the ends of its opening on the wall, m
    (None: a recording from before it was kept)."""


DOOR_WIDTH_M = 0.9
"""How wide the door drawn where people leave is, m."""


def door_on_wall(
    width_m: float, height_m: float, exit_xy: tuple[float, float]
) -> tuple[tuple[float, float], tuple[float, float]]:
    """The ends of a door ``DOOR_WIDTH_M`` wide on the wall nearest ``exit_xy`` (the exit
    people walk to), centred where the exit meets that wall and kept on it."""
    x, y = exit_xy
    walls = ((x, "left"), (width_m - x, "right"), (y, "bottom"), (height_m - y, "top"))
    side = min(walls)[1]
    along, length = (y, height_m) if side in ("left", "right") else (x, width_m)
    half = min(DOOR_WIDTH_M, length) / 2
    low = min(max(along - half, 0.0), length - 2 * half)
    if side in ("left", "right"):
        at = 0.0 if side == "left" else width_m
        return (at, low), (at, low + 2 * half)
    at = 0.0 if side == "bottom" else height_m
    return (low, at), (low + 2 * half, at)
