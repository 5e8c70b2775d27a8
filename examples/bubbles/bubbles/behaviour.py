"""The ``chase_bubbles`` behaviour: a child runs to where bubbles float around the robot."""

from __future__ import annotations

import math
from collections.abc import Mapping

from oimi.scenarios.simulation.humans import BehaviourView


class ChaseBubbles:
    """Picks a spot ``near_m``..``far_m`` from the robot, runs there, pauses, picks another."""

    def __init__(self, options: Mapping[str, float | str]) -> None:
        self.near_m = float(options.get("near_m", 0.7))
        self.far_m = float(options.get("far_m", 1.6))
        self.pause_ms = round(float(options.get("pause_s", 1.0)) * 1000)
        self._target: tuple[float, float] | None = None
        self._until_ms = 0

    def velocity(self, view: BehaviourView) -> tuple[float, float]:
        if view.time_ms < self._until_ms:
            return (0.0, 0.0)
        if self._target is None:
            angle = view.rng.uniform(-math.pi, math.pi)
            reach = view.rng.uniform(self.near_m, self.far_m)
            x = view.robot[0] + reach * math.cos(angle)
            y = view.robot[1] + reach * math.sin(angle)
            self._target = (
                min(max(x, 0.3), view.arena.width_m - 0.3),
                min(max(y, 0.3), view.arena.height_m - 0.3),
            )
        dx, dy = self._target[0] - view.position[0], self._target[1] - view.position[1]
        gap = math.hypot(dx, dy)
        if gap <= view.speed_mps * view.dt_s:
            self._target = None
            self._until_ms = view.time_ms + self.pause_ms
            return (dx / view.dt_s, dy / view.dt_s)
        return (dx / gap * view.speed_mps, dy / gap * view.speed_mps)
