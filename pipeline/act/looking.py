"""Since when each camera has looked without a break (the safety supervisor's).

While a sonar is down the robot drives only where the camera looks. A camera whose frames
may all miss a child for ``camera_miss_ms`` (a scenario's ``dropout_probability``, a real
person tracker) shows an empty view to be empty only once it has framed that long: one that
just came back (from offline, frozen or late) may not yet have reported a child standing
right ahead, and the robot, let drive at once, would close on them meanwhile.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Final

from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.messages import Camera

_NEVER: Final = -math.inf


class CameraWatch:
    """Per camera, the frame that began its current unbroken run of frames (each tick's
    latest frame within ``max_frame_age_ms``; a frame more than a tick ahead of the session's
    clock breaks it, as it cannot be trusted)."""

    def __init__(self, config: SafetyConfig, *, tick_ms: int) -> None:
        """``config``: filled (its ``max_frame_age_ms`` and ``camera_miss_ms``)."""
        self._max_age_ms: int = config.max_frame_age_ms  # type: ignore[assignment]  # filled
        self.miss_ms: int = config.camera_miss_ms  # type: ignore[assignment]  # filled
        self._ahead_ms = tick_ms
        self._since: dict[str, float] = {}

    def framing(
        self, cameras: Sequence[Camera], beats: Mapping[tuple[str, str], int], now_ms: int
    ) -> list[Camera]:
        """The cameras that frame at ``now_ms``: their latest frame (``MapProducer.beats``)
        within ``max_frame_age_ms``, and not more than a tick ahead (a frozen camera still
        says it is on). Called every tick, stands too: with ``camera_miss_ms``, since when
        each has framed is noted, and a break while the robot stands counts."""
        oldest_ms, newest_ms = now_ms - self._max_age_ms, now_ms + self._ahead_ms
        framing = [
            c for c in cameras if oldest_ms <= beats.get(("Camera", c.id), _NEVER) <= newest_ms
        ]
        if self.miss_ms:  # a run goes on from its first frame; a camera not framing has none
            since = self._since
            for camera in framing:
                if camera.id not in since:
                    since[camera.id] = beats[("Camera", camera.id)]
            if len(since) > len(framing):  # (rarely: a run broke)
                ids = {camera.id for camera in framing}
                self._since = {ident: at for ident, at in since.items() if ident in ids}
        return framing

    def looked(self, framing: Sequence[Camera], now_ms: int) -> bool:
        """Whether one of the ``framing`` cameras (frames fresh at this tick) has framed for
        ``camera_miss_ms`` since its run began (a child in its view then has been
        reported)."""
        if not self.miss_ms:
            return bool(framing)
        since = self._since
        return any(now_ms - since.get(c.id, now_ms) >= self.miss_ms for c in framing)
