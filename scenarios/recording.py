"""Recording a session: the MCAP and Rerun sinks, opened with everything a replay needs."""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Protocol

from pipeline.events import Event, Topic
from recorder.mcap_sink import McapSink
from recorder.rerun_sink import RerunSink
from recorder.scene import ObstacleGeometry, SceneGeometry
from scenarios.runner import Session
from scenarios.schema import Scenario
from scenarios.session_info import SESSION_RECORD, SessionInfo, TickCounter


def scene_of(scenario: Scenario) -> SceneGeometry:
    """The arena and its furniture, for the recorders' static scene."""
    world = scenario.world
    return SceneGeometry(
        width_m=world.width_m,
        height_m=world.height_m,
        obstacles=tuple(
            ObstacleGeometry(
                id=o.id,
                kind=str(o.kind),
                x_m=o.x_m,
                y_m=o.y_m,
                width_m=o.width_m,
                height_m=o.height_m,
                radius_m=o.radius_m,
                angle_rad=o.angle_rad,
            )
            for o in world.obstacles
        ),
    )


def recording_id(scenario: Scenario) -> str:
    """A fixed id for a scenario and seed, so a re-run writes the same recording id."""
    return f"{scenario.name}-seed{scenario.seed}"


class ClosingSink(Protocol):
    """A sink that ``recorded`` closes at the end (a live Foxglove server, for one)."""

    def record(self, topic: Topic, time_ns: int, message: Event) -> None: ...

    def close(self) -> None: ...


@contextlib.contextmanager
def recorded(
    session: Session,
    *,
    mcap: Path | None,
    rrd: Path | None,
    info: SessionInfo | None = None,
    sinks: Sequence[ClosingSink] = (),
) -> Iterator[Session]:
    """Attach the MCAP (and Rerun) sinks to a session, and close them whatever happens.

    The sinks open before the first tick, with the session's metadata and
    attachments at the start of the file; Ctrl-C or an error still closes them, and
    a second Ctrl-C while they close is ignored. ``info`` makes it a live session's
    recording: its own recording id, and a ``session`` record written at the start
    and again at the end with the true ``ticks`` and ``duration_s``. ``sinks`` are
    added after the recorders and closed with them.
    """
    closers: list[McapSink | RerunSink | ClosingSink] = []
    rid = recording_id(session.scenario) if info is None else info.recording_id
    counter = TickCounter(session.tick_ms)
    mcap_sink: McapSink | None = None
    try:
        closers.extend(sinks)
        if info is not None:
            session.sink.add(counter)
        if mcap is not None:
            mcap.parent.mkdir(parents=True, exist_ok=True)
            metadata = session.metadata()
            metadata["oimi"]["recording_id"] = rid
            if info is not None:
                metadata[SESSION_RECORD] = info.record()
            sink = McapSink(
                mcap,
                metadata=metadata,
                attachments=session.attachments(),
                scene=scene_of(session.scenario),
            )
            closers.append(sink)
            session.sink.add(sink)
            mcap_sink = sink
        if rrd is not None:
            rrd.parent.mkdir(parents=True, exist_ok=True)
            rerun = RerunSink(rrd, recording_id=rid, scene=scene_of(session.scenario))
            closers.append(rerun)
            session.sink.add(rerun)
        for extra in sinks:
            session.sink.add(extra)
        yield session
    finally:
        with interrupts_held():
            try:
                if info is not None and mcap_sink is not None:
                    ended = {**info.record(), **counter.elapsed()}
                    mcap_sink.add_metadata(SESSION_RECORD, ended)
            finally:
                for closer in closers:
                    closer.close()


@contextlib.contextmanager
def interrupts_held() -> Iterator[None]:
    """Ignore Ctrl-C (SIGINT) for the duration, so that a second Ctrl-C cannot cut a file
    short while it is being finished; a no-op outside the main thread."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
