"""The Rerun sink: the session as an ``.rrd`` with a default layout, and MCAP -> RRD.

An explicit ``RecordingStream`` (no global state) with a fixed recording id, no
wall-clock timelines (``log_time``/``log_tick`` off, no recording properties),
timelines ``sim_time`` (simulated seconds) and ``tick``. Rerun's 2D views point
y down: world coordinates are drawn with y negated so the arena reads like a map.
The SDK writing a file sends no usage data (Rerun's analytics live in its viewer:
``rerun analytics disable``).
"""

from __future__ import annotations

import json
import math
import os
from collections import deque
from collections.abc import Sequence
from typing import Final

import msgspec
import rerun as rr
import rerun.blueprint as rrb

from pipeline.events import (
    ActuatorCommands,
    BodyState,
    Event,
    Level,
    LogEntries,
    OperatorCommands,
    ReaderProgress,
    RuleChainState,
    RuleDecisions,
    Topic,
    WorldState,
)
from pipeline.messages import InstructionBlock
from recorder.errors import RecordingError
from recorder.reader import Recording, open_recording
from recorder.scene import SceneGeometry
from recorder.topics import METADATA_OIMI, SCENE_ATTACHMENT

DEFAULT_WORLD_EVERY_N_TICKS: Final = 5
DEFAULT_TRAIL_SAMPLES: Final = 200
"""Points kept in each trail (at every 5th tick of 50 Hz: the last 20 s)."""
TRAIL_EVERY_N_SAMPLES: Final = 5
"""Trails are re-drawn every 5th world sample (1 Hz at the defaults)."""
COLUMN_BATCH_SAMPLES: Final = 250
"""World samples buffered before they are sent as columns (50 s at the defaults)."""

_RGB = tuple[int, int, int]
LED_OFF: Final[_RGB] = (140, 140, 140)
ROLE_COLORS: Final[dict[str, _RGB]] = {"child": (255, 153, 26), "therapist": (51, 115, 242)}
OTHER_HUMAN: Final[_RGB] = (153, 77, 204)
OBJECT: Final[_RGB] = (51, 204, 77)
OBSTACLE: Final[_RGB] = (128, 102, 77)
ARENA: Final[_RGB] = (90, 90, 102)
LEVELS: Final[dict[Level, str]] = {
    Level.DEBUG: rr.TextLogLevel.DEBUG,
    Level.INFO: rr.TextLogLevel.INFO,
    Level.WARNING: rr.TextLogLevel.WARN,
    Level.ERROR: rr.TextLogLevel.ERROR,
}


def default_blueprint() -> rrb.Blueprint:
    """The world on the left, plots in the middle, the script and text logs on the right."""
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(name="World", origin="world"),
            rrb.Vertical(
                rrb.TimeSeriesView(name="Speed (m/s)", origin="robot/speed"),
                rrb.TimeSeriesView(name="Distance to humans (m)", origin="robot/distance"),
                rrb.TimeSeriesView(name="LEDs", origin="robot/leds"),
            ),
            rrb.Vertical(
                rrb.TextDocumentView(name="Current block", origin="script/block"),
                rrb.TextLogView(name="Script", origin="script/events"),
                rrb.TextLogView(name="Rules fired", origin="rules"),
                rrb.TextLogView(name="Log", origin="log"),
            ),
            column_shares=[3, 2, 2],
        ),
        collapse_panels=False,
    )


def _xy(x_m: float, y_m: float) -> list[float]:
    return [x_m, -y_m]


class RerunSink:
    """Logs events to an ``.rrd`` file; a context manager; a ``Sink``.

    World entities, trails, speed and distances are logged every
    ``world_every_n_ticks`` ticks (and on the first world state); texts as they come.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        recording_id: str,
        scene: SceneGeometry | None = None,
        application_id: str = "oimi",
        world_every_n_ticks: int = DEFAULT_WORLD_EVERY_N_TICKS,
        trail_samples: int = DEFAULT_TRAIL_SAMPLES,
    ) -> None:
        if world_every_n_ticks < 1:
            raise RecordingError(f"world_every_n_ticks must be >= 1, got {world_every_n_ticks}")
        self._rec = rr.RecordingStream(
            application_id, recording_id=recording_id, send_properties=False
        )
        try:
            self._rec.save(os.fspath(path), default_blueprint=default_blueprint())
        except Exception as error:  # the bindings raise plain exceptions on IO errors
            raise RecordingError(f"cannot write: {error}", source=os.fspath(path)) from None
        self._rec.set_log_time_enabled(False)
        self._rec.set_log_tick_enabled(False)
        self._every = world_every_n_ticks
        self._trail_samples = trail_samples
        self._trails: dict[str, deque[list[float]]] = {}
        self._tick: int | None = None
        self._seconds = 0.0
        self._time_set = False
        self._samples = 0
        self._series: dict[str, _Series] = {}
        self._led: tuple[float, float, float] | None = None
        self._audio: str | None = None
        self._place: tuple[str, str, str, str] | None = None
        self._block: InstructionBlock | None = None
        self._closed = False
        self._static()
        if scene is not None:
            self._scene(scene)

    # ------------------------------------------------------------- static

    def _static(self) -> None:
        log = self._rec.log
        log("robot/speed", rr.SeriesLines(names="speed", widths=2), static=True)
        log(
            "robot/leds",
            rr.SeriesLines(colors=[(255, 0, 0), (0, 200, 0), (0, 0, 255)], names=["r", "g", "b"]),
            static=True,
        )

    def _scene(self, scene: SceneGeometry) -> None:
        log = self._rec.log
        log(
            "world/arena",
            rr.Boxes2D(
                mins=[0.0, -scene.height_m],
                sizes=[scene.width_m, scene.height_m],
                colors=ARENA,
                labels="arena",
                show_labels=False,
            ),
            static=True,
        )
        boxes = [o for o in scene.obstacles if not o.is_disc]
        discs = [o for o in scene.obstacles if o.is_disc]
        if boxes:
            log(
                "world/obstacles/boxes",
                rr.LineStrips2D(
                    [_box_outline(o.x_m, o.y_m, o.width_m, o.height_m, o.angle_rad) for o in boxes],
                    colors=OBSTACLE,
                    labels=[o.kind or o.id for o in boxes],
                ),
                static=True,
            )
        if discs:
            log(
                "world/obstacles/discs",
                rr.Points2D(
                    [_xy(o.x_m, o.y_m) for o in discs],
                    radii=[o.radius_m for o in discs],
                    colors=OBSTACLE,
                    labels=[o.kind or o.id for o in discs],
                ),
                static=True,
            )

    # --------------------------------------------------------------- Sink

    def record(self, topic: Topic, time_ns: int, message: Event) -> None:
        """Log one event at simulated time ``time_ns``."""
        if self._closed:
            raise RecordingError(f"record({topic}) after close()")
        if message.tick != self._tick:
            self._tick = message.tick
            self._seconds = time_ns / 1e9
            self._time_set = False
        match message:
            case WorldState():
                self._world(message)
            case ReaderProgress():
                self._progress(message)
            case ActuatorCommands() if message.block is not None:
                self._block = message.block
                self._block_document()
            case RuleDecisions():
                self._decisions(message)
            case RuleChainState() if message.applied:
                self._chain(message)
            case LogEntries():
                self._log(message)
            case OperatorCommands():
                for c in message.commands:
                    text = f"#{c.id} {c.verb.value} {c.activity}".rstrip()
                    self._emit("log/operator", rr.TextLog(text, level=rr.TextLogLevel.INFO))
            case _:
                pass

    def _emit(self, path: str, archetype: rr.AsComponents) -> None:
        """Log now, at the current tick (the timelines are set lazily, once per tick)."""
        if not self._time_set:
            self._time_set = True
            self._rec.set_time("tick", sequence=self._tick or 0)
            self._rec.set_time("sim_time", duration=self._seconds)
        self._rec.log(path, archetype)

    def _world(self, state: WorldState) -> None:
        if state.led != self._led:
            self._led = state.led
            self._emit("robot/leds", rr.Scalars(list(state.led)))
        if state.audio != self._audio:
            self._audio = state.audio
            text = f"playing {state.audio}" if state.audio else "silence"
            self._emit("robot/audio", rr.TextLog(text))
        if self._samples and state.tick % self._every:
            return
        self._samples += 1
        robot = state.robot
        r = robot.radius_m or 0.2
        colour = LED_OFF if not any(state.led) else tuple(round(255 * c) for c in state.led)
        heading = _xy(1.5 * r * math.cos(robot.theta_rad), 1.5 * r * math.sin(robot.theta_rad))
        buffer = self._buffer
        buffer(
            "world/robot",
            rr.Points2D,
            positions=_xy(robot.x_m, robot.y_m),
            radii=r,
            colors=colour,
            labels="robot",
        )
        buffer(
            "world/robot/heading",
            rr.Arrows2D,
            origins=_xy(robot.x_m, robot.y_m),
            vectors=heading,
            colors=(255, 255, 255),
        )
        buffer("robot/speed", rr.Scalars, scalars=math.hypot(robot.vx_mps, robot.vy_mps))
        self._trail("world/robot/trail", robot, colour)
        for human in state.humans:
            colour_h = ROLE_COLORS.get(human.kind, OTHER_HUMAN)
            buffer(
                f"world/humans/{human.id}",
                rr.Points2D,
                positions=_xy(human.x_m, human.y_m),
                radii=human.radius_m or 0.2,
                colors=colour_h,
                labels=human.id,
            )
            distance = math.hypot(human.x_m - robot.x_m, human.y_m - robot.y_m)
            buffer(f"robot/distance/{human.id}", rr.Scalars, scalars=distance)
            self._trail(f"world/humans/{human.id}/trail", human, colour_h)
        for obj in state.objects:
            buffer(
                f"world/objects/{obj.id}",
                rr.Points2D,
                positions=_xy(obj.x_m, obj.y_m),
                radii=obj.radius_m or 0.1,
                colors=OBJECT,
                labels=obj.id,
            )
        if self._samples % COLUMN_BATCH_SAMPLES == 0:
            self._send_columns()

    def _buffer(self, path: str, archetype: type, **fields: object) -> None:
        """Queue one row of a sampled entity; rows go to Rerun in batches (``send_columns``)."""
        series = self._series.get(path)
        if series is None:
            series = self._series[path] = _Series(archetype)
        series.add(self._tick or 0, self._seconds, fields)

    def _send_columns(self) -> None:
        for path, series in self._series.items():
            if series.ticks:
                self._rec.send_columns(path, indexes=series.indexes(), columns=series.columns())
                series.clear()

    def _trail(self, path: str, body: BodyState, colour: Sequence[int]) -> None:
        trail = self._trails.get(path)
        if trail is None:
            trail = self._trails[path] = deque(maxlen=self._trail_samples)
        trail.append(_xy(body.x_m, body.y_m))
        if len(trail) > 1 and (self._samples - 1) % TRAIL_EVERY_N_SAMPLES == 0:
            self._emit(path, rr.LineStrips2D([list(trail)], colors=colour, radii=0.02))

    def _progress(self, progress: ReaderProgress) -> None:
        place = (progress.activity, progress.goalid, progress.actionid, progress.blockid)
        if place != self._place:
            self._place = place
            self._block_document()
        for item in progress.items:
            where = f" at {item.path}" if item.path else ""
            detail = f": {item.detail}" if item.detail else ""
            self._emit(
                "script/events",
                rr.TextLog(f"{item.kind.value} {item.activity}{where}{detail}", level="INFO"),
            )

    def _block_document(self) -> None:
        activity, goal, action, block = self._place or ("", "", "", "")
        lines = [f"**{activity or '(no activity)'}** `{goal}/{action}/{block}`"]
        if self._block is not None:
            body = json.dumps(json.loads(msgspec.json.encode(self._block)), indent=2)
            lines += ["", "```json", body, "```"]
        self._emit("script/block", rr.TextDocument("\n".join(lines), media_type="text/markdown"))

    def _decisions(self, decisions: RuleDecisions) -> None:
        for d in decisions.decisions:
            if not d.fired:
                continue
            parts = [f"{d.rule} (rule {d.rulecode}) fired"]
            if d.bindings:
                parts.append(", ".join(f"{k}={v}" for k, v in d.bindings.items()))
            parts.extend(f"{c.path}: {c.old} -> {c.new}" for c in d.changes)
            self._emit("rules/decisions", rr.TextLog("; ".join(parts), level="INFO"))

    def _chain(self, chain: RuleChainState) -> None:
        applied = ", ".join(f"{m.action.name} {m.id}" for m in chain.applied)
        text = f"{applied}; active: {', '.join(chain.active) or '-'}"
        if chain.locked:
            text += " (locked)"
        self._emit("rules/chain", rr.TextLog(text, level="INFO"))

    def _log(self, entries: LogEntries) -> None:
        for e in entries.entries:
            ref = f" [{e.ref}]" if e.ref else ""
            self._emit(
                "log",
                rr.TextLog(f"{e.source}: {e.message}{ref}", level=LEVELS.get(e.level, "INFO")),
            )

    # ---------------------------------------------------------- lifecycle

    def close(self) -> None:
        """Flush everything to the file and detach it. Idempotent."""
        if self._closed:
            return
        self._closed = True
        self._send_columns()
        self._rec.flush()
        self._rec.disconnect()

    def __enter__(self) -> RerunSink:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


class _Series:
    """Buffered rows of one entity: timeline values and per-row component values."""

    def __init__(self, archetype: type) -> None:
        self.archetype = archetype
        self.ticks: list[int] = []
        self.seconds: list[float] = []
        self.fields: dict[str, list[object]] = {}

    def add(self, tick: int, seconds: float, fields: dict[str, object]) -> None:
        self.ticks.append(tick)
        self.seconds.append(seconds)
        for name, value in fields.items():
            self.fields.setdefault(name, []).append(value)

    def indexes(self) -> list[rr.TimeColumn]:
        return [
            rr.TimeColumn("tick", sequence=self.ticks),
            rr.TimeColumn("sim_time", duration=self.seconds),
        ]

    def columns(self) -> object:
        return self.archetype.columns(**self.fields)

    def clear(self) -> None:
        self.ticks.clear()
        self.seconds.clear()
        self.fields.clear()


def _box_outline(x: float, y: float, w: float, h: float, angle: float) -> list[list[float]]:
    c, s = math.cos(angle), math.sin(angle)
    corners = [(-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2), (-w / 2, -h / 2)]
    return [_xy(x + c * dx - s * dy, y + s * dx + c * dy) for dx, dy in corners]


def recording_id_of(metadata: dict[str, dict[str, str]], fallback: str) -> str:
    """The Rerun recording id of a recording: ``oimi.recording_id`` when the runner set it."""
    return metadata.get(METADATA_OIMI, {}).get("recording_id") or fallback


def mcap_to_rrd(
    mcap_path: str | os.PathLike[str],
    rrd_path: str | os.PathLike[str],
    *,
    world_every_n_ticks: int = DEFAULT_WORLD_EVERY_N_TICKS,
) -> Recording:
    """Convert an oimi MCAP recording to an ``.rrd`` through :class:`RerunSink`.

    The scene comes from the ``oimi/scene.json`` attachment when present. A damaged
    MCAP is converted up to its damage; the returned recording's ``recovery`` says
    how much was read (None for an intact file).
    """
    recording = open_recording(mcap_path)
    source = os.fspath(mcap_path)
    scene = None
    if SCENE_ATTACHMENT in recording.attachments:
        try:
            scene = msgspec.json.decode(recording.attachments[SCENE_ATTACHMENT], type=SceneGeometry)
        except msgspec.DecodeError as error:
            raise RecordingError(f"{SCENE_ATTACHMENT}: {error}", source=source) from None
    stem = os.path.splitext(os.path.basename(source))[0]
    with RerunSink(
        rrd_path,
        recording_id=recording_id_of(recording.metadata, stem),
        scene=scene,
        world_every_n_ticks=world_every_n_ticks,
    ) as sink:
        for message in recording.iter_messages():
            sink.record(message.topic, message.time_ns, message.decoded())
    return recording
