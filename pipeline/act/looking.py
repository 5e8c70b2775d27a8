"""Since when each camera has looked without a break (the safety supervisor's).

While a sonar is down the robot drives only where the camera looks. A camera whose frames
may all miss a child for ``camera_miss_ms`` (a scenario's ``dropout_probability``, a real
person tracker) shows an empty view to be empty only once it has framed that long: one that
just came back (from offline, frozen or late) may not yet have reported a child standing
right ahead, and the robot, let drive at once, would close on them meanwhile.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.messages import Camera


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

    def watch(
        self, cameras: Sequence[Camera], beats: Mapping[tuple[str, str], int], now_ms: int
    ) -> None:
        """Note this tick's frames (``MapProducer.beats``): every tick, so that a break while
        the robot stands counts too. Nothing to note for a camera that misses nobody."""
        if not self.miss_ms:
            return
        oldest_ms, newest_ms = now_ms - self._max_age_ms, now_ms + self._ahead_ms
        since = self._since
        for camera in cameras:  # (in place, a loop: a tick's cost, most ticks no change)
            ident = camera.id
            beat = beats.get(("Camera", ident))
            if beat is not None and oldest_ms <= beat <= newest_ms:
                if ident not in since:
                    since[ident] = beat
            elif ident in since:
                del since[ident]
        if len(since) > len(cameras):  # a camera gone from the map: not framing either
            ids = {camera.id for camera in cameras}
            self._since = {ident: at for ident, at in since.items() if ident in ids}

    def looked(self, framing: Sequence[Camera], now_ms: int) -> bool:
        """Whether one of the ``framing`` cameras (frames fresh at this tick) has framed for
        ``camera_miss_ms`` since its run began (a child in its view then has been
        reported)."""
        if not self.miss_ms:
            return bool(framing)
        since = self._since
        return any(now_ms - since.get(c.id, now_ms) >= self.miss_ms for c in framing)
