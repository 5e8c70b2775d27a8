"""CameraWatch: since when a camera has framed without a break (``camera_miss_ms``)."""

from __future__ import annotations

from oimi.pipeline.act.looking import CameraWatch
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.messages import Camera

FRONT = Camera(id="front", isonline=True)


def watched(frames: dict[int, int], miss_ms: int, until_ms: int) -> list[int]:
    """The ticks (20 ms) at which the camera counts as having looked, its latest frame at
    each tick being ``frames[tick_ms]`` (or the one before) with frames every 100 ms."""
    watch = CameraWatch(
        SafetyConfig(max_frame_age_ms=500, camera_miss_ms=miss_ms).filled(), tick_ms=20
    )
    latest, looked = None, []
    for now_ms in range(0, until_ms, 20):
        latest = frames.get(now_ms, latest)
        beats = {} if latest is None else {("Camera", "front"): latest}
        framing = watch.framing([FRONT], beats, now_ms)
        if watch.looked(framing, now_ms):
            looked.append(now_ms)
    return looked


def test_a_camera_counts_once_it_has_framed_for_its_misses_since_its_first_frame() -> None:
    frames = {t: t for t in range(200, 3000, 100)}
    assert watched(frames, 300, 1000)[0] == 500  # its first frame at 200, then 300 ms
    assert watched(frames, 0, 1000)[0] == 200  # a camera that misses nobody: at once


def test_a_break_in_the_frames_starts_the_wait_again() -> None:
    """Frames until 1000 ms, none until 1700 (older than max_frame_age_ms from 1520 on):
    the camera counts again only 300 ms after its first frame back, 1700."""
    frames = {t: t for t in [*range(0, 1001, 100), *range(1700, 3000, 100)]}
    looked = watched(frames, 300, 3000)
    assert 1500 in looked and 1520 not in looked  # the last frame 500 ms old, then 520
    assert next(t for t in looked if t > 1520) == 2000


def test_a_camera_gone_from_the_map_and_back_waits_again() -> None:
    """Its frames fresh all along, but the map lost the camera for a tick: back, it counts
    only once it has framed for ``camera_miss_ms`` again (nothing says what it saw)."""
    watch = CameraWatch(SafetyConfig(max_frame_age_ms=500, camera_miss_ms=300).filled(), tick_ms=20)
    beats = {("Camera", "front"): 0}
    for now_ms in range(0, 400, 20):
        watch.framing([FRONT], beats, now_ms)
    assert watch.looked([FRONT], 380)
    watch.framing([], {}, 400)
    beats[("Camera", "front")] = 400
    watch.framing([FRONT], beats, 420)
    assert not watch.looked([FRONT], 420) and watch.looked([FRONT], 700)
