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
