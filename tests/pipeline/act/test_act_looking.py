"""SensorWatch: since when a camera or a sonar has worked without a break (``camera_miss_ms``,
``sonar_miss_ms``)."""

from __future__ import annotations

from oimi.pipeline.act.looking import SensorWatch
from oimi.pipeline.messages import Camera, Sonar

FRONT = Camera(id="front", isonline=True)


def watched(frames: dict[int, int], miss_ms: int, until_ms: int) -> list[int]:
    """The ticks (20 ms) at which the camera counts as having looked, its latest frame at
    each tick being ``frames[tick_ms]`` (or the one before) with frames every 100 ms."""
    watch = SensorWatch("Camera", 500, miss_ms, 20)
    latest, looked = None, []
    for now_ms in range(0, until_ms, 20):
        latest = frames.get(now_ms, latest)
        beats = {} if latest is None else {("Camera", "front"): latest}
        working = watch.working([FRONT], beats, now_ms)
        if watch.looked(working, now_ms):
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
    watch = SensorWatch("Camera", 500, 300, 20)
    beats = {("Camera", "front"): 0}
    for now_ms in range(0, 400, 20):
        watch.working([FRONT], beats, now_ms)
    assert watch.looked([FRONT], 380)
    watch.working([], {}, 400)
    beats[("Camera", "front")] = 400
    watch.working([FRONT], beats, 420)
    assert not watch.looked([FRONT], 420) and watch.looked([FRONT], 700)


def test_a_ring_settles_once_every_sonar_has_scanned_for_its_misses() -> None:
    """Two sonars scanning every 200 ms, the second gone from 1000 ms to 1400 (the map lost
    it): the ring settles 600 ms after the first scans, and again only 600 ms after that
    sonar's first scan back, whatever the other's run."""
    left, right = Sonar(id="left", isonline=True), Sonar(id="right", isonline=True)
    watch = SensorWatch("Sonar", 500, 600, 20)
    settled = []
    for now_ms in range(0, 2400, 20):
        scan_ms = now_ms - now_ms % 200
        beats = {("Sonar", "left"): scan_ms}
        if not 1000 <= now_ms < 1400:
            beats[("Sonar", "right")] = scan_ms
        working = watch.working([left, right], beats, now_ms)
        if len(working) == 2 and watch.settled(working, now_ms):
            settled.append(now_ms)
    assert settled[0] == 600 and 980 in settled
    assert next(t for t in settled if t >= 1000) == 2000
    assert SensorWatch("Sonar", 500, 0, 20).settled([left], 0)
