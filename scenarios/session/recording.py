"""Recording a session: the MCAP and Rerun sinks, opened with everything a replay needs."""

from __future__ import annotations

import contextlib
import datetime
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

import msgspec
from oimi.pipeline.errors import LocatedError
from oimi.pipeline.events import Event, Topic
from oimi.recorder.mcap_sink import DEFAULT_CHUNK_SIZE_BYTES, McapSink
from oimi.recorder.metadata import RecordingMetadata, StoppedRecord
from oimi.recorder.outputs import (
    check_outputs,
    claim_partial,
    finish_partial,
    partial_path,
)
from oimi.recorder.scene import ObstacleGeometry, SafetyZones, SceneGeometry, door_on_wall
from oimi.recorder.world_sampling import DEFAULT_WORLD_EVERY_N_TICKS
from oimi.scenarios.schema import Scenario
from oimi.scenarios.session.info import SESSION_RECORD, SessionInfo, TickCounter
from oimi.scenarios.session.interrupts import interrupts_held
from oimi.scenarios.session.runner import Session

if TYPE_CHECKING:  # rerun (and numpy, with its BLAS threads) only for a Rerun recording
    from oimi.recorder.rerun_sink import RerunSink


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
        safety=SafetyZones(
            stop_m=scenario.robot.safety.stop_distance_m,
            slow_m=scenario.robot.safety.slow_distance_m,
        ),
        door=door_on_wall(world.width_m, world.height_m, world.exit_point),
    )


def recording_id(scenario: Scenario) -> str:
    """A fixed id for a scenario and seed, so a re-run writes the same recording id."""
    return f"{scenario.name}-seed{scenario.seed}"


class ClosingSink(Protocol):
    """A sink that ``recorded`` closes at the end (a live Foxglove server, for one)."""

    def record(self, topic: Topic, time_ns: int, message: Event) -> None: ...

    def close(self) -> None: ...


def dated_path(folder: Path, name: str, suffix: str, *, now: datetime.datetime) -> Path:
    """``folder/NAME-2026-11-23T16-20-05.mcap`` (``-2``, ``-3``... when that is taken), so two
    sessions never share a file; ``now`` is the wall clock, read by the caller."""
    stem = f"{name}-{now.strftime('%Y-%m-%dT%H-%M-%S')}"
    path = folder / f"{stem}{suffix}"
    number = 1
    while path.exists() or partial_path(path).exists():
        number += 1
        path = folder / f"{stem}-{number}{suffix}"
    return path


def stop_reason(error: BaseException) -> str:
    """Why a session stopped before its end, for its recording's ``stopped`` record."""
    if isinstance(error, KeyboardInterrupt):
        return "interrupted (Ctrl-C)"
    if isinstance(error, LocatedError):
        return str(error)
    return f"{type(error).__name__}: {error}" if str(error) else type(error).__name__


@contextlib.contextmanager
def recorded(
    session: Session,
    *,
    mcap: Path | None,
    rrd: Path | None,
    overwrite: bool = True,
    chunk_size_bytes: int = DEFAULT_CHUNK_SIZE_BYTES,
    world_every_n_ticks: int = DEFAULT_WORLD_EVERY_N_TICKS,
    info: SessionInfo | None = None,
    final_info: Callable[[], SessionInfo] | None = None,
    sinks: Sequence[ClosingSink] = (),
) -> Iterator[Session]:
    """Attach the MCAP (and Rerun) sinks to a session, and close them whatever happens.

    Both outputs are checked (:func:`check_outputs`) before either is opened; each is
    written to its :func:`partial_path`, created exclusively, and renamed to its name
    once closed, so a killed session leaves ``NAME.partial.mcap`` and never a damaged
    ``NAME.mcap``; without ``overwrite`` an existing file is refused, never replaced.
    The sinks open before the first tick, with the session's metadata and
    attachments at the start of the file; Ctrl-C or an error still closes them, and
    a second Ctrl-C while they close is ignored. ``chunk_size_bytes`` bounds what a
    killed session loses (the open chunk); ``world_every_n_ticks`` how often the MCAP
    keeps ``/world/state`` (``recorder.world_sampling``). ``info`` makes it a live session's
    recording: its own recording id, and a ``session`` record written at the start
    and again at the end with the true ``ticks`` and ``duration_s`` (and the fields of
    ``final_info()`` when given: the console may change them). ``sinks`` are
    added after the recorders and closed with them.
    """
    check_outputs((mcap, rrd), overwrite=overwrite)
    claimed: list[tuple[Path, Path]] = []
    opened: list[tuple[McapSink | RerunSink, Path, Path]] = []
    closers: list[ClosingSink] = list(sinks)
    started = False
    scene = scene_of(session.scenario)
    ident = recording_id(session.scenario) if info is None else info.recording_id
    counter = TickCounter(session.tick_ms)
    mcap_sink: McapSink | None = None
    try:
        if info is not None:
            session.sink.add(counter)
        for path in (mcap, rrd):
            if path is not None:
                claimed.append((path, claim_partial(path, overwrite=overwrite)))
        for path, partial in claimed:
            if path is mcap:
                metadata = session.metadata()
                metadata = msgspec.structs.replace(
                    metadata,
                    oimi=msgspec.structs.replace(metadata.oimi, recording_id=ident),
                    session=None if info is None else info.record(),
                )
                mcap_sink = McapSink(
                    partial,
                    metadata=metadata.records(),
                    attachments=session.attachments(),
                    scene=scene,
                    chunk_size_bytes=chunk_size_bytes,
                    world_every_n_ticks=world_every_n_ticks,
                )
                sink: McapSink | RerunSink = mcap_sink
            else:
                from oimi.recorder.rerun_sink import RerunSink

                sink = RerunSink(partial, recording_id=ident, scene=scene)
            opened.append((sink, partial, path))
            session.sink.add(sink)
        for extra in sinks:
            session.sink.add(extra)
        started = True
        yield session
    except BaseException as error:
        stopped = RecordingMetadata(stopped=StoppedRecord(reason=stop_reason(error)))
        # the recording says why it ends early; the error to report is the first one
        with contextlib.suppress(Exception):
            if mcap_sink is not None:
                for name, record in stopped.records().items():
                    mcap_sink.add_metadata(name, record)
        raise
    finally:
        with interrupts_held():
            try:
                if info is not None and mcap_sink is not None:
                    last = info if final_info is None else final_info()
                    mcap_sink.add_metadata(
                        SESSION_RECORD,
                        msgspec.to_builtins(
                            msgspec.structs.replace(last.record(), **counter.elapsed())
                        ),
                    )
            finally:
                for closer in closers:
                    closer.close()
                for sink, _, _ in opened:
                    sink.close()
                for path, partial in claimed:
                    if started:
                        finish_partial(partial, path, overwrite=overwrite)
                    else:  # it never recorded anything: withdraw the claim
                        partial.unlink(missing_ok=True)
