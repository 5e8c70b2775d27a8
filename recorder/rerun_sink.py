"""The Rerun sink: the session as an ``.rrd`` with a default layout, and MCAP -> RRD.

An explicit ``RecordingStream`` (no global state) with a fixed recording id, no
wall-clock timelines (``log_time``/``log_tick`` off, no recording properties),
timelines ``sim_time`` (simulated seconds) and ``tick``. Rerun's 2D views point
y down: world coordinates are drawn with y negated so the arena reads like a map.
Colours come from :mod:`recorder.palette`. The SDK writing a file sends no usage
data (the viewer's privacy is ``oimi view``'s: docs/security.md#viewer-privacy).

Long module: one sink: the layout (blueprint) and the logging of every topic
share the entity paths and palette; the MCAP -> RRD conversion reuses the same logging.
"""

from __future__ import annotations

import itertools
import math
import os
from collections import deque
from typing import Final

import msgspec
import rerun as rr
import rerun.blueprint as rrb
from oimi.pipeline.events import (
    ActuatorCommands,
    BodyState,
    Event,
    Level,
    LogEntries,
    OperatorCommands,
    ReaderProgress,
    RuleChainState,
    RuleDecisions,
    SafetyIntervention,
    SafetyPhase,
    SafetyZone,
    Topic,
    WorldState,
)
from oimi.pipeline.messages import (
    AudioOut,
    InstructionBlock,
    Led,
    Move,
    MutexCmd,
    RuleAction,
    RuleMessage,
)
from oimi.pipeline.operator.commands import describe
from oimi.pipeline.texts import clipped
from oimi.recorder import palette
from oimi.recorder.errors import RecordingError
from oimi.recorder.metadata import RecordingMetadata
from oimi.recorder.palette import RGB
from oimi.recorder.reader import Recording, open_recording
from oimi.recorder.scene import SafetyZones, SceneGeometry
from oimi.recorder.topics import SCENE_ATTACHMENT

DEFAULT_WORLD_EVERY_N_TICKS: Final = 5
DEFAULT_TRAIL_SAMPLES: Final = 100
"""Points kept in each trail (at every 5th tick of 50 Hz: the last 10 s)."""
TRAIL_EVERY_N_SAMPLES: Final = 5
"""Trails are re-drawn every 5th world sample (1 Hz at the defaults)."""
COLUMN_BATCH_SAMPLES: Final = 250
"""World samples buffered before they are sent as columns (50 s at the defaults)."""
DEFAULT_ZONES: Final = SafetyZones()
"""Drawn until the safety supervisor's own configuration reaches the sink."""
RING_POINTS: Final = 48
NAME_OFFSET_M: Final = 0.22
TRAIL_ALPHA: Final = 150
"""Trails are drawn translucent, in their body's colour."""
LEVELS: Final[dict[Level, str]] = {
    Level.DEBUG: rr.TextLogLevel.DEBUG,
    Level.INFO: rr.TextLogLevel.INFO,
    Level.WARNING: rr.TextLogLevel.WARN,
    Level.ERROR: rr.TextLogLevel.ERROR,
}
PANES: Final = {"script": "script", "robot": "sound", "rules": "rules", "log": "log"}
"""The text tab each text entity's first path segment goes to (``robot/audio``: Sound)."""
RECENT_LINES: Final = 9
"""Lines a text tab shows at most: the newest at the bottom of the pane at 1280x800."""
RECENT_ROW_CHARS: Final = 72
"""Characters in a row of a text tab at 1280x800: a longer line wraps and takes the room
of more lines, so fewer are shown."""
# draw order, back to front
_GRID, _ARENA, _TRAIL, _ZONE, _BODY, _RING, _INK, _MARK = 0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0


def default_blueprint(scene: SceneGeometry | None = None) -> rrb.Blueprint:
    """The room gets most of the screen; beside it what the robot does now, the LED band,
    distances and speed, then the texts up to the time cursor in tabs. Side panels
    collapsed, time in seconds."""
    bounds = None
    if scene is not None:
        bounds = rrb.VisualBounds2D(
            x_range=[-0.5, scene.width_m + 0.3], y_range=[-scene.height_m - 0.3, 0.5]
        )
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(name="Room", origin="world", visual_bounds=bounds),
            rrb.Vertical(
                rrb.TextDocumentView(name="Now", origin="script/block"),
                rrb.TimeSeriesView(
                    name="LED colour",
                    origin="robot/led",
                    axis_y=rrb.ScalarAxis(range=(0.5, 1.5), zoom_lock=True),  # one label: 1
                    plot_legend=rrb.PlotLegend(visible=False),
                    # the robot's body colour: a white LED vanished on the plot's white
                    background=rrb.archetypes.PlotBackground(color=palette.colour("robot")),
                ),
                rrb.TimeSeriesView(name="Gap to each person (m)", origin="robot/distance"),
                rrb.TimeSeriesView(
                    name="Speed (m/s)",
                    origin="robot/speed",
                    plot_legend=rrb.PlotLegend(visible=False),
                ),
                rrb.Tabs(
                    *(
                        rrb.TextDocumentView(name=pane.title(), origin=f"recent/{pane}")
                        for pane in PANES.values()
                    )
                ),
                # at 1280x800 a plot much shorter than 1.6 shows only its 0 label
                row_shares=[1.4, 0.8, 1.6, 1.6, 1.9],
            ),
            column_shares=[3, 2],
        ),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline="sim_time"),
    )


def _fitting(lines: deque[str]) -> list[str]:
    """The last of ``lines`` that fill at most RECENT_LINES rows once wrapped (the newest
    always)."""
    kept: list[str] = []
    rows = 0
    for line in reversed(lines):
        rows += -(-len(line) // RECENT_ROW_CHARS)
        if kept and rows > RECENT_LINES:
            break
        kept.append(line)
    return kept[::-1]


def _xy(x_m: float, y_m: float) -> list[float]:
    return [x_m, -y_m]


_RING_STEP: Final = 2 * math.pi / RING_POINTS
_UNIT_RING: Final = tuple(
    (math.cos(i * _RING_STEP), math.sin(i * _RING_STEP)) for i in range(RING_POINTS + 1)
)
"""The closed unit circle a ring is drawn from (computed once: rings are drawn each tick)."""


def _ring(x_m: float, y_m: float, radius_m: float) -> list[list[float]]:
    return [[x_m + radius_m * c, -(y_m + radius_m * s)] for c, s in _UNIT_RING]


def zone_rings(
    radius_m: float, zones: SafetyZones, acting: str | None
) -> tuple[list[list[list[float]]], list[RGB], list[float]]:
    """The slow and stop rings of a person of ``radius_m`` (plus each zone's distance),
    around the origin (a transform moves them with the person): line strips, colours,
    line radii. The ``acting`` zone (``slow``, ``stop`` or None) is drawn bold; the
    others thin and dimmed."""
    strips, colours, widths = [], [], []
    for name, distance in (("slow", zones.slow_m), ("stop", zones.stop_m)):
        strips.append(_ring(0.0, 0.0, radius_m + distance))
        full = palette.colour(f"{name}-zone")
        bold = name == acting
        colours.append(full if bold else tuple(c * 3 // 5 for c in full))
        widths.append(0.035 if bold else 0.01)
    return strips, colours, widths


def _drawn_zone(zone: SafetyZone | str | None) -> str | None:
    """The ring a supervisor zone lights: ``stop`` and ``slow`` their own (``stale`` and
    ``blind`` caps are not about one person's distance: no ring)."""
    return str(zone) if zone in (SafetyZone.STOP, SafetyZone.SLOW) else None


def _under(body: BodyState) -> list[float]:
    """Where a body's name goes: just below it, clear of its disc."""
    return _xy(body.x_m, body.y_m - body.radius_m - NAME_OFFSET_M)


def _name_tag(name: str, colour: RGB) -> rr.Points2D:
    """The static part of a name tag: a label on an invisible point."""
    return rr.Points2D.from_fields(
        radii=0.001, colors=colour, labels=name, show_labels=True, draw_order=_MARK
    )


def _gap(a: BodyState, b: BodyState) -> float:
    """Surface-to-surface distance of two discs, m (negative when they overlap)."""
    return math.hypot(a.x_m - b.x_m, a.y_m - b.y_m) - a.radius_m - b.radius_m


class RerunSink:
    """Logs events to an ``.rrd`` file; a context manager; a ``Sink``.

    World entities, trails, speed and distances are logged every
    ``world_every_n_ticks`` ticks (the first state of each such window of ticks); texts
    as they come.
    ``zones`` are the safety zones drawn around each person.
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
        zones: SafetyZones | None = None,
    ) -> None:
        if world_every_n_ticks < 1:
            raise RecordingError(f"world_every_n_ticks must be >= 1, got {world_every_n_ticks}")
        self._rec = rr.RecordingStream(
            application_id, recording_id=recording_id, send_properties=False
        )
        try:
            self._rec.save(os.fspath(path), default_blueprint=default_blueprint(scene))
        except Exception as error:  # the bindings raise plain exceptions on IO errors
            raise RecordingError(f"cannot write: {error}", source=os.fspath(path)) from None
        self._rec.set_log_time_enabled(False)
        self._rec.set_log_tick_enabled(False)
        self._every = world_every_n_ticks
        self._trail_samples = trail_samples
        self._zones = zones or (scene.safety if scene is not None else DEFAULT_ZONES)
        self._acting: dict[str, str | None] | None = None
        """The zone the supervisor acts in per person, from ``/safety`` (None: no such topic
        seen yet, so the zone is read off the geometry)."""
        self._trails: dict[str, deque[list[float]]] = {}
        self._looks: dict[str, tuple[object, ...]] = {}
        """What each ring entity last drew (ring radius, colour or zone): rings are drawn
        around the origin when that changes and moved by a transform each sample."""
        self._tick: int | None = None
        self._seconds = 0.0
        self._time_set = False
        self._samples = 0
        self._window = -1
        """The last sample's tick // ``world_every_n_ticks``: one sample per window, the
        first state in it (a recording's states need not fall on its first tick)."""
        self._series: dict[tuple[str, type], _Series] = {}
        self._seen: set[str] = set()
        self._present: tuple[str, ...] = ()
        """The people in the room at the last sample, in order."""
        self._people = palette.PersonColours()
        """People seen of each kind: their colours go by order of appearance."""
        self._led: tuple[float, float, float] | None = None
        self._audio: str | None = None
        self._contacts: tuple[str, ...] = ()
        self._firing: dict[str, dict[str, str]] = {}
        """The rules that fired at the last evaluation, with their bindings."""
        self._place: tuple[str, str, str, str] | None = None
        self._block: InstructionBlock | None = None
        self._recent = {pane: deque[str](maxlen=RECENT_LINES) for pane in PANES.values()}
        self._stale: set[str] = set()
        """Tabs with lines added this tick, redrawn once when the tick ends."""
        self._closed = False
        self._static()
        if scene is not None:
            self._scene(scene)

    # ------------------------------------------------------------- static

    def _static(self) -> None:
        log = self._rec.log
        robot = palette.colour("robot")
        log("robot/speed", rr.SeriesLines(names="speed", colors=robot, widths=2), static=True)
        log(
            "robot/led",
            rr.SeriesPoints(names="LED", markers="square", marker_sizes=7),
            static=True,
        )
        log(
            "world/robot",
            rr.Points2D.from_fields(colors=robot, draw_order=_BODY),
            static=True,
        )
        log("world/robot/name", _name_tag("robot", palette.colour("arena")), static=True)
        log(
            "world/robot/led",
            rr.LineStrips2D.from_fields(radii=0.045, draw_order=_RING),
            static=True,
        )
        log(
            "world/robot/heading",
            rr.Arrows2D.from_fields(
                colors=palette.colour("robot-ink"), radii=0.025, draw_order=_INK
            ),
            static=True,
        )
        log(
            "world/robot/trail",
            rr.LineStrips2D.from_fields(
                colors=(*robot, TRAIL_ALPHA), radii=0.012, draw_order=_TRAIL
            ),
            static=True,
        )

    def _scene(self, scene: SceneGeometry) -> None:
        log = self._rec.log
        width, height = scene.width_m, scene.height_m
        grid = [[_xy(x, 0.0), _xy(x, height)] for x in range(math.floor(width) + 1)]
        grid += [[_xy(0.0, y), _xy(width, y)] for y in range(math.floor(height) + 1)]
        log(
            "world/grid",
            rr.LineStrips2D(grid, colors=palette.colour("grid"), radii=0.006, draw_order=_GRID),
            static=True,
        )
        marks = [(x, -0.25) for x in range(math.floor(width) + 1)]
        log(
            "world/grid/metres",
            rr.Points2D(
                [_xy(x, y) for x, y in marks],
                radii=0.01,
                colors=palette.colour("grid"),
                labels=[f"{x} m" for x, _ in marks],
                show_labels=True,
                draw_order=_GRID,
            ),
            static=True,
        )
        log(
            "world/arena",
            rr.LineStrips2D(
                [[_xy(0, 0), _xy(width, 0), _xy(width, height), _xy(0, height), _xy(0, 0)]],
                colors=palette.colour("arena"),
                radii=0.02,
                draw_order=_ARENA,
            ),
            static=True,
        )
        if scene.door is not None:
            log(
                "world/door",
                rr.LineStrips2D(
                    [[_xy(*end) for end in scene.door]],
                    colors=palette.colour("door"),
                    radii=0.05,
                    labels=["door"],
                    draw_order=_ARENA,
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
                    colors=palette.colour("obstacle"),
                    radii=0.02,
                    labels=[o.kind or o.id for o in boxes],
                    draw_order=_ARENA,
                ),
                static=True,
            )
        if discs:
            log(
                "world/obstacles/discs",
                rr.Points2D(
                    [_xy(o.x_m, o.y_m) for o in discs],
                    radii=[o.radius_m for o in discs],
                    colors=palette.colour("obstacle"),
                    labels=[o.kind or o.id for o in discs],
                    draw_order=_ARENA,
                ),
                static=True,
            )

    def _first_sight(self, body: BodyState, *, person: bool) -> None:
        """Static colours and labels of a person or object, logged when it first appears."""
        if body.id in self._seen:
            return
        self._seen.add(body.id)
        log = self._rec.log
        if not person:
            log(
                f"world/objects/{body.id}",
                rr.Points2D.from_fields(
                    colors=palette.colour("object"),
                    labels=body.id,
                    show_labels=True,
                    draw_order=_BODY,
                ),
                static=True,
            )
            return
        colour = self._people.of(body.id, body.kind)
        log(
            f"world/humans/{body.id}",
            rr.Points2D.from_fields(colors=colour, draw_order=_BODY),
            static=True,
        )
        log(f"world/humans/{body.id}/name", _name_tag(body.id, colour), static=True)
        log(
            f"world/humans/{body.id}/trail",
            rr.LineStrips2D.from_fields(
                colors=(*colour, TRAIL_ALPHA), radii=0.012, draw_order=_TRAIL
            ),
            static=True,
        )
        log(
            f"world/humans/{body.id}/zones",
            rr.LineStrips2D.from_fields(draw_order=_ZONE),
            static=True,
        )
        log(
            f"robot/distance/{body.id}",
            rr.SeriesLines(names=body.id, colors=colour, widths=2),
            static=True,
        )

    # --------------------------------------------------------------- Sink

    def record(self, topic: Topic, time_ns: int, message: Event) -> None:
        """Log one event at simulated time ``time_ns``."""
        if self._closed:
            raise RecordingError(f"record({topic}) after close()")
        if message.tick != self._tick:
            self._show_recent()
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
            case SafetyIntervention():
                acting = self._acting if self._acting is not None else {}
                self._acting = acting
                acting[message.human] = None if message.phase == SafetyPhase.END else message.zone
            case OperatorCommands():
                for c in message.commands:
                    self._say("log/operator", f"#{c.id} {describe(c)}")
            case _:
                pass

    def _say(self, path: str, text: str, level: str = rr.TextLogLevel.INFO) -> None:
        """A line of text, led by the simulated time in seconds, logged and added to its tab."""
        stamp = f"{self._seconds:7.2f} s  "
        self._emit(path, rr.TextLog(stamp + text, level=level))
        pane = PANES[path.split("/")[0]]
        flag = "" if level == rr.TextLogLevel.INFO else f"{level}  "
        self._recent[pane].append(stamp + flag + text)
        self._stale.add(pane)

    def _show_recent(self) -> None:
        """Each tab whose lines changed this tick, as a document of its last lines: Rerun's
        text log view lists lines after the time cursor too, a document shows the latest
        one up to it."""
        for pane in sorted(self._stale):
            self._emit(f"recent/{pane}", rr.TextDocument("\n".join(_fitting(self._recent[pane]))))
        self._stale.clear()

    def _emit(self, path: str, archetype: rr.AsComponents) -> None:
        """Log now, at the current tick (the timelines are set lazily, once per tick)."""
        if not self._time_set:
            self._time_set = True
            self._rec.set_time("tick", sequence=self._tick or 0)
            self._rec.set_time("sim_time", duration=self._seconds)
        self._rec.log(path, archetype)

    def _world(self, state: WorldState) -> None:
        changed = state.led != self._led
        if changed:
            self._led = state.led
        if state.audio != self._audio:
            self._audio = state.audio
            # the track's file name, as the block's line says it (a script may give a path)
            text = f"sound {os.path.basename(state.audio)}" if state.audio else "sound off"
            self._say("robot/audio", text)
        if state.contacts != self._contacts:
            self._contact(state)
        if state.tick // self._every == self._window:
            if changed:
                self._buffer("robot/led", rr.SeriesPoints, colors=palette.led_rgb(state.led))
                self._buffer("robot/led", rr.Scalars, scalars=1.0)
            return
        self._samples += 1
        self._window = state.tick // self._every
        robot = state.robot
        r = robot.radius_m
        led = palette.led_rgb(state.led)
        self._buffer("robot/led", rr.SeriesPoints, colors=led)
        self._buffer("robot/led", rr.Scalars, scalars=1.0)
        buffer = self._buffer
        buffer("world/robot", rr.Points2D, positions=_xy(robot.x_m, robot.y_m), radii=r)
        buffer("world/robot/name", rr.Points2D, positions=_under(robot))
        self._moved("world/robot/led", robot)
        if self._changed_look("world/robot/led", r, led):
            buffer("world/robot/led", rr.LineStrips2D, strips=_ring(0.0, 0.0, r * 0.72), colors=led)
        heading = _xy(1.2 * r * math.cos(robot.theta_rad), 1.2 * r * math.sin(robot.theta_rad))
        buffer(
            "world/robot/heading",
            rr.Arrows2D,
            origins=_xy(robot.x_m, robot.y_m),
            vectors=heading,
        )
        buffer("robot/speed", rr.Scalars, scalars=math.hypot(robot.vx_mps, robot.vy_mps))
        self._trail("world/robot/trail", robot)
        if state.contacts:
            self._contact(state)
        self._departures(state)
        for human in state.humans:
            self._first_sight(human, person=True)
            path = f"world/humans/{human.id}"
            buffer(path, rr.Points2D, positions=_xy(human.x_m, human.y_m), radii=human.radius_m)
            buffer(f"{path}/name", rr.Points2D, positions=_under(human))
            gap = _gap(robot, human)
            acting = (
                self._zones.acting(gap)
                if self._acting is None
                else _drawn_zone(self._acting.get(human.id))
            )
            self._moved(f"{path}/zones", human)
            if self._changed_look(f"{path}/zones", human.radius_m, acting):
                strips, colours, widths = zone_rings(human.radius_m, self._zones, acting)
                self._buffer(
                    f"{path}/zones", rr.LineStrips2D, 2, strips=strips, colors=colours, radii=widths
                )
            buffer(f"robot/distance/{human.id}", rr.Scalars, scalars=max(gap, 0.0))
            self._trail(f"{path}/trail", human)
        for obj in state.objects:
            self._first_sight(obj, person=False)
            buffer(
                f"world/objects/{obj.id}",
                rr.Points2D,
                positions=_xy(obj.x_m, obj.y_m),
                radii=obj.radius_m or 0.1,
            )
        if self._samples % COLUMN_BATCH_SAMPLES == 0:
            self._send_columns()

    def _contact(self, state: WorldState) -> None:
        """Contact episodes: a mark between the robot and each person it touches, and a
        warning in the log when an episode starts or ends."""
        started = [h for h in state.contacts if h not in self._contacts]
        ended = [h for h in self._contacts if h not in state.contacts]
        self._contacts = state.contacts
        for human_id in started:
            self._say(
                "log/safety", f"contact: robot touches {human_id}", level=rr.TextLogLevel.WARN
            )
        for human_id in ended:
            self._say("log/safety", f"contact with {human_id} ended")
        robot = state.robot
        touching = [h for h in state.humans if h.id in state.contacts]
        if not touching:
            self._emit("world/contacts", rr.Clear(recursive=False))
            return
        self._emit(
            "world/contacts",
            rr.Points2D(
                [_xy((robot.x_m + h.x_m) / 2, (robot.y_m + h.y_m) / 2) for h in touching],
                radii=0.09,
                colors=palette.colour("contact"),
                labels="contact",
                show_labels=True,
                draw_order=_MARK,
            ),
        )

    def _departures(self, state: WorldState) -> None:
        """Clear the people who left the room since the last sample: their body, name,
        zones, trail and distance plot end there (drawn anew if they come back); say who
        left and who came back."""
        present = tuple(h.id for h in state.humans)
        if present == self._present:
            return
        for human_id in present:
            if human_id not in self._present and human_id in self._seen:
                self._say("log/world", f"{human_id} came back into the room")
        for human_id in self._present:
            if human_id in present:
                continue
            path = f"world/humans/{human_id}"
            self._emit(path, rr.Clear(recursive=True))
            self._emit(f"robot/distance/{human_id}", rr.Clear(recursive=False))
            self._trails.pop(f"{path}/trail", None)
            self._looks.pop(f"{path}/zones", None)
            self._say("log/world", f"{human_id} left the room")
        self._present = present

    def _moved(self, path: str, body: BodyState) -> None:
        """Place ``path``'s origin at ``body`` for this sample."""
        self._buffer(path, rr.Transform3D, translation=[body.x_m, -body.y_m, 0.0])

    def _changed_look(self, path: str, *look: object) -> bool:
        """Whether ``path``'s drawing differs from what it last drew (and note it)."""
        if self._looks.get(path) == look:
            return False
        self._looks[path] = look
        return True

    def _buffer(self, path: str, archetype: type, count: int = 1, **fields: object) -> None:
        """Queue one row of a sampled entity (``count`` instances, each field a list of
        that many when count > 1); rows go to Rerun in batches (``send_columns``)."""
        series = self._series.get((path, archetype))
        if series is None:
            series = self._series[path, archetype] = _Series(archetype)
        series.add(self._tick or 0, self._seconds, fields, count)

    def _send_columns(self) -> None:
        for (path, _), series in self._series.items():
            if series.ticks:
                self._rec.send_columns(path, indexes=series.indexes(), columns=series.columns())
                series.clear()

    def _trail(self, path: str, body: BodyState) -> None:
        trail = self._trails.get(path)
        if trail is None:
            trail = self._trails[path] = deque(maxlen=self._trail_samples)
        trail.append(_xy(body.x_m, body.y_m))
        if len(trail) > 1 and (self._samples - 1) % TRAIL_EVERY_N_SAMPLES == 0:
            self._buffer(path, rr.LineStrips2D, strips=list(trail))

    def _progress(self, progress: ReaderProgress) -> None:
        place = (progress.activity, progress.goalid, progress.actionid, progress.blockid)
        if place != self._place:
            self._place = place
            self._block = None  # the old place's: the new one's comes with the next commands
            self._block_document()
        for item in progress.items:
            where = f" at {item.path}" if item.path else ""
            detail = f": {item.detail}" if item.detail else ""
            self._say("script/events", f"{item.kind.value} {item.activity}{where}{detail}")

    def _block_document(self) -> None:
        activity, goal, action, block = self._place or ("", "", "", "")
        where = f"{goal}/{action}/{block}" if goal else "-"
        lines = [f"**{activity or '(no activity)'}** · {where}"]
        if self._block is not None:  # body-sized lines that wrap: a heading was cut at 1280 px
            lines += ["", *(f"- {line}" for line in block_lines(self._block))]
        self._emit("script/block", rr.TextDocument("\n".join(lines), media_type="text/markdown"))

    def _decisions(self, decisions: RuleDecisions) -> None:
        """A rule that starts firing, fires with other bindings or changes the map; one
        that stops (a condition that holds fired at every evaluation, a flood of one line)."""
        firing: dict[str, dict[str, str]] = {}
        for d in decisions.decisions:
            if not d.fired:
                if d.rule in self._firing:
                    self._say("rules/decisions", f"{d.rule} (rule {d.rulecode}) stopped firing")
                continue
            firing[d.rule] = d.bindings
            if not d.changes and self._firing.get(d.rule) == d.bindings:
                continue
            parts = [f"{d.rule} (rule {d.rulecode}) fired"]
            if d.bindings:
                parts.append(", ".join(f"{k}={v}" for k, v in d.bindings.items()))
            parts.extend(
                f"{c.path}: {value_words(c.path, c.old)} -> {value_words(c.path, c.new)}"
                for c in d.changes
            )
            self._say("rules/decisions", "; ".join(parts))
        self._firing = firing

    def _chain(self, chain: RuleChainState) -> None:
        text = f"{chain_words(chain.applied)}; active: {', '.join(chain.active) or '-'}"
        if chain.locked:
            text += " (map locked)"
        self._say("rules/chain", text)

    def _log(self, entries: LogEntries) -> None:
        for e in entries.entries:
            ref = f" [{e.ref}]" if e.ref else ""
            self._say("log", f"{e.source}: {e.message}{ref}", level=LEVELS.get(e.level, "INFO"))

    # ---------------------------------------------------------- lifecycle

    def close(self) -> None:
        """Flush everything to the file and detach it. Idempotent."""
        if self._closed:
            return
        self._closed = True
        self._show_recent()
        self._send_columns()
        self._rec.flush()
        self._rec.disconnect()

    def __enter__(self) -> RerunSink:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


class _Series:
    """Buffered rows of one entity and archetype: timeline values and component values."""

    def __init__(self, archetype: type) -> None:
        self.archetype = archetype
        self.ticks: list[int] = []
        self.seconds: list[float] = []
        self.lengths: list[int] = []
        self.fields: dict[str, list[object]] = {}

    def add(self, tick: int, seconds: float, fields: dict[str, object], count: int) -> None:
        self.ticks.append(tick)
        self.seconds.append(seconds)
        self.lengths.append(count)
        for name, value in fields.items():
            column = self.fields.setdefault(name, [])
            if count == 1:
                column.append(value)
            else:
                column.extend(value)  # type: ignore[call-overload]

    def indexes(self) -> list[rr.TimeColumn]:
        return [
            rr.TimeColumn("tick", sequence=self.ticks),
            rr.TimeColumn("sim_time", duration=self.seconds),
        ]

    def columns(self) -> object:
        columns = self.archetype.columns(**self.fields)
        if any(n != 1 for n in self.lengths):
            columns = columns.partition(self.lengths)
        return columns

    def clear(self) -> None:
        self.ticks.clear()
        self.seconds.clear()
        self.lengths.clear()
        self.fields.clear()


def _box_outline(x: float, y: float, w: float, h: float, angle: float) -> list[list[float]]:
    c, s = math.cos(angle), math.sin(angle)
    corners = [(-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2), (-w / 2, -h / 2)]
    return [_xy(x + c * dx - s * dy, y + s * dx + c * dy) for dx, dy in corners]


def block_lines(block: InstructionBlock) -> list[str]:
    """What a block makes the robot do, in words, a line per channel (a run of one item
    said once, with its count): ``MV 0.15 m/s for 2.0 s``, ``LED yellow → dim blue ×3``,
    ``sound hello.wav``."""
    channels = [("MV ", block.move), ("LED ", block.led), ("sound ", block.audioout)]
    lines = [
        name + " → ".join(_runs([_channel_words(x) for x in items]))
        for name, items in channels
        if items
    ]
    return lines or ["nothing"]


def _move_words(move: Move) -> str:
    speed = math.hypot(move.v_x, move.v_y)
    parts = [f"{speed:.2f} m/s"] if speed else []
    if move.v_theta:
        parts.append(f"turn {move.v_theta:.2f} rad/s")
    text = " ".join(parts) or "stand still"
    text += f" for {move.duration / 1000:.1f} s"
    if move.wait_t:
        text += f" after {move.wait_t / 1000:.1f} s"
    return text


def _runs(items: list[str]) -> list[str]:
    """Each run of equal items once, with its length when more than one."""
    runs = [(item, len(list(group))) for item, group in itertools.groupby(items)]
    return [item if n == 1 else f"{item} ×{n}" for item, n in runs]


_DONE: Final = {
    RuleAction.A: "added",
    RuleAction.R: "removed",
    RuleAction.D: "held for later",
    RuleAction.B: "brought back",
    RuleAction.C: "recovered",
}
"""What an alfa/omega action did to its rule, in words (thesis 4.3; the Rules pane)."""


def chain_words(applied: tuple[RuleMessage, ...]) -> str:
    """Alfa/omega messages in words, in order, a run of one action said once:
    ``map locked · removed kick_starter · added avoid, greet · map unlocked``."""
    steps: list[tuple[str, str]] = []
    for m in applied:
        if m.mutexcmd == MutexCmd.L:
            steps.append(("map locked", ""))
        steps.append((_DONE[m.action], m.id))
        if m.mutexcmd == MutexCmd.U:
            steps.append(("map unlocked", ""))
    said = []
    for done, run in itertools.groupby(steps, key=lambda step: step[0]):
        rules = ", ".join(rule for _, rule in run if rule)
        said.append(f"{done} {rules}" if rules else done)
    return " · ".join(said)


_BLOCK_CHANNELS: Final = {"move": Move, "led": Led, "audioout": AudioOut}
MAX_VALUE_CHARS: Final = 40
"""A changed value other than a block's channel is cut here (the pane's width)."""


def value_words(path: str, value: str) -> str:
    """A value a rule changed (JSON text, cut at its end by the pipeline) as a designer
    reads it: a block's moves, LEDs or sounds in words, else the JSON, short."""
    section, _, channel = path.rpartition(".")
    kind = _BLOCK_CHANNELS.get(channel)
    if section.endswith("block") and kind is not None and value.startswith("["):
        cut = not value.endswith("]")  # the whole items before the cut are said
        whole = value[: value.rfind("},") + 1] + "]" if cut else value
        try:
            items = msgspec.json.decode(whole, type=list[kind])
        except msgspec.DecodeError:
            pass
        else:
            words = " → ".join(_runs([_channel_words(x) for x in items])) or "none"
            return words + " → …" if cut else words
    return clipped(value, MAX_VALUE_CHARS)


def _channel_words(item: Move | Led | AudioOut) -> str:
    match item:
        case Move():
            return _move_words(item)
        case Led():
            return palette.colour_name((item.r, item.g, item.b)) if item.turnas else "off"
        case AudioOut():
            return os.path.basename(item.track_path)


def recording_id_of(metadata: RecordingMetadata, fallback: str) -> str:
    """The Rerun recording id of a recording: ``oimi.recording_id`` when the runner set it."""
    return metadata.oimi.recording_id or fallback


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
        recording_id=recording_id_of(recording.meta, stem),
        scene=scene,
        world_every_n_ticks=world_every_n_ticks,
    ) as sink:
        for message in recording.iter_messages():
            sink.record(message.topic, message.time_ns, message.decoded())
    return recording
