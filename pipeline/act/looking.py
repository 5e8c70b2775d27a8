"""Since when each camera and each sonar has looked without a break (the safety supervisor's).

While a sonar is down the robot drives only where the camera looks. A camera whose frames
may all miss a child for ``camera_miss_ms`` (a scenario's ``dropout_probability``, a real
person tracker) shows an empty view to be empty only once it has framed that long: one that
just came back (from offline, frozen or late) may not yet have reported a child standing
right ahead, and the robot, let drive at once, would close on them meanwhile. A sonar ring
whose scans may all miss a body for ``sonar_miss_ms`` counts as up only once every sonar has
scanned that long, for the same reason beside and behind the robot.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Final

from oimi.pipeline.messages import Camera, Sonar

_NEVER: Final = -math.inf


class SensorWatch:
    """Per sensor of one class (``"Camera"`` or ``"Sonar"``), the frame or scan that began
    its current unbroken run (each tick's latest within ``max_age_ms``; one more than a tick
    ahead of the session's clock breaks it, as it cannot be trusted)."""

    def __init__(self, klass: str, max_age_ms: int, miss_ms: int, tick_ms: int) -> None:
        """``miss_ms``: how long the sensor's frames or scans may all miss a child in its
        view (``camera_miss_ms``, ``sonar_miss_ms``); 0, never."""
        self._klass = klass
        self._max_age_ms = max_age_ms
        self.miss_ms = miss_ms
        self._ahead_ms = tick_ms
        self._since: dict[str, float] = {}

    def working(
        self, sensors: Sequence[Camera | Sonar], beats: Mapping[tuple[str, str], int], now_ms: int
    ) -> list[Camera | Sonar]:
        """The ``sensors`` that frame or scan at ``now_ms``: their latest frame or scan
        (``MapProducer.beats``) within ``max_age_ms``, and not more than a tick ahead (a
        frozen sensor still says it is on). Called every tick, stands too: with ``miss_ms``,
        since when each has worked is noted, and a break while the robot stands counts."""
        klass = self._klass
        oldest_ms, newest_ms = now_ms - self._max_age_ms, now_ms + self._ahead_ms
        working = [s for s in sensors if oldest_ms <= beats.get((klass, s.id), _NEVER) <= newest_ms]
        if self.miss_ms:  # a run goes on from its first beat; a sensor not working has none
            since = self._since
            for sensor in working:
                if sensor.id not in since:
                    since[sensor.id] = beats[(klass, sensor.id)]
            if len(since) > len(working):  # (rarely: a run broke)
                ids = {sensor.id for sensor in working}
                self._since = {ident: at for ident, at in since.items() if ident in ids}
        return working

    def looked(self, working: Sequence[Camera | Sonar], now_ms: int) -> bool:
        """Whether one of the ``working`` sensors (:meth:`working` at this tick) has worked
        for ``miss_ms`` since its run began (a child in its view then has been reported)."""
        if not self.miss_ms:
            return bool(working)
        since = self._since
        return any(now_ms - since[s.id] >= self.miss_ms for s in working)

    def settled(self, working: Sequence[Camera | Sonar], now_ms: int) -> bool:
        """Whether every one of the ``working`` sensors has worked for ``miss_ms`` since its
        run began (:meth:`began_ms`)."""
        return now_ms - self.began_ms(working) >= self.miss_ms

    def began_ms(self, working: Sequence[Camera | Sonar]) -> float:
        """Since when every one of the ``working`` sensors has worked without a break, ms
        (with no ``miss_ms``: ever, -inf; none working: never, inf)."""
        if not self.miss_ms:
            return -math.inf
        since = self._since
        return max([since[s.id] for s in working]) if working else math.inf
