"""Recording a session: the MCAP and Rerun sinks, opened with everything a replay needs."""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from pathlib import Path

from recorder.mcap_sink import McapSink
from recorder.rerun_sink import RerunSink
from recorder.scene import ObstacleGeometry, SceneGeometry
from scenarios.runner import Session
from scenarios.schema import Scenario


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


@contextlib.contextmanager
def recorded(session: Session, *, mcap: Path | None, rrd: Path | None) -> Iterator[Session]:
    """Attach the MCAP (and Rerun) sinks to a session, and close them whatever happens.

    The sinks open before the first tick, with the session's metadata and
    attachments at the start of the file; Ctrl-C or an error still closes them, and
    a second Ctrl-C while they close is ignored.
    """
    closers: list[McapSink | RerunSink] = []
    try:
        if mcap is not None:
            mcap.parent.mkdir(parents=True, exist_ok=True)
            metadata = session.metadata()
            metadata["oimi"]["recording_id"] = recording_id(session.scenario)
            sink = McapSink(
                mcap,
                metadata=metadata,
                attachments=session.attachments(),
                scene=scene_of(session.scenario),
            )
            closers.append(sink)
            session.sink.add(sink)
        if rrd is not None:
            rrd.parent.mkdir(parents=True, exist_ok=True)
            rerun = RerunSink(
                rrd, recording_id=recording_id(session.scenario), scene=scene_of(session.scenario)
            )
            closers.append(rerun)
            session.sink.add(rerun)
        yield session
    finally:
        with interrupts_held():
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
