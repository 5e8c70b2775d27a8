"""The scenario runner: world + sensors + pipeline + sinks, ticked by the simulated clock.

Each tick: the world steps with the actuator's current outputs; the sensors
sample it and the scenario's events fall due; then the pipeline's loop runs
once. Everything goes to the sinks; a ``Tracker`` checks the expectations.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol

import msgspec
from oimi.pipeline.act.safety_lock import SafetyLock
from oimi.pipeline.events import (
    JoystickInput,
    SafetyZone,
    Topic,
    WorldState,
)
from oimi.pipeline.messages import ActuatorOutputs, MapUpdate
from oimi.pipeline.operator.commands import Add, GetReady, OperatorCommand, Start
from oimi.pipeline.registries import Registries
from oimi.pipeline.sink import NS_PER_MS, Sink
from oimi.recorder.metadata import (
    RecordingMetadata,
)
from oimi.scenarios.loader import LoadedScenario
from oimi.scenarios.schema import (
    BehaviourEvent,
    FaultEvent,
    JoystickEvent,
    OperatorEvent,
    TouchEvent,
)
from oimi.scenarios.session.activities import ACTIVITIES
from oimi.scenarios.session.build import build_pipeline
from oimi.scenarios.session.expectations import Verdict
from oimi.scenarios.session.interrupts import interrupts_between_ticks
from oimi.scenarios.session.watchdog import watching
from oimi.scenarios.simulation.sensors import Sensors
from oimi.scenarios.simulation.world import World, stream_rng

AUTO_START_COMMANDS = (GetReady, Start)
"""A scenario whose events send one of these drives the session itself; others auto-start."""


class Summary(msgspec.Struct, frozen=True, kw_only=True):
    """What a session did, for the end-of-run report."""

    scenario: str
    seed: int
    ticks: int
    duration_s: float
    """Simulated time: ``ticks`` times the tick's length, s."""
    activities: dict[str, str]
    """The operator's selection at the end, with each activity's state."""
    goals_reached: dict[str, int]
    rules_fired: dict[str, int]
    """Per rule, the evaluations whose condition held (a touch held 300 ms counts several)."""
    min_distance_m: dict[str, float]
    max_speed_mps: float
    contacts: int
    rejected_inputs: int
    safety_interventions: int = 0
    """Episodes in which the safety supervisor limited the robot's velocity."""
    protective_stops: int = 0
    """Those of them that reached the stop zone."""
    min_surface_distance_m: dict[str, float] = {}
    """Closest surface-to-surface distance per human (``pipeline.proximity``), m."""
    contact_episodes: int = 0
    robot_initiated_contacts: int = 0
    pushed_contacts: int = 0
    """Contacts in which another person pushed the robot into this one
    (``pipeline.proximity.Initiator.PUSHED``)."""
    max_closing_speed_mps: float = 0.0
    """The fastest a gap closed at the start of a contact episode, m/s."""
    rule_episodes: dict[str, int] = {}
    """Per rule that fired, its firing episodes: runs of evaluations that held."""
    errors: tuple[str, ...] = ()
    """Each ERROR the session logged (``1.00 s rules: rule 'r' (code 1010) raised ...``)."""
    ran: dict[str, str] = {}
    """Each activity that ran (the idle activity aside) with its last state, selected at
    the end or not (``Tracker.ran``)."""


class RunResult(msgspec.Struct, frozen=True, kw_only=True):
    summary: Summary
    verdicts: tuple[Verdict, ...]

    @property
    def ok(self) -> bool:
        return all(v.ok for v in self.verdicts)


class Body(Protocol):
    """What a session ticks as the robot's surroundings: the simulated ``World``, or a
    robot that is somewhere else (``oimi.ros2.remote.RemoteBody``)."""

    led: tuple[float, float, float]
    audio: str

    def step(self, outputs: ActuatorOutputs, *, tick: int) -> object: ...

    def apply_event(self, event: BehaviourEvent) -> None: ...

    def state(self, *, tick: int, time_ms: int) -> WorldState: ...


class SensorInputs(Protocol):
    """Where a session's map updates come from: the simulated ``Sensors``, or updates that
    arrive from elsewhere (``oimi.ros2.remote.RemoteSensors``)."""

    def sample(self, world: Any, *, tick: int, time_ms: int) -> list[MapUpdate]: ...

    def touch(self, event: TouchEvent, *, time_ms: int) -> None: ...

    def fault(self, event: FaultEvent) -> None: ...


class Session:
    """One scenario, set up and ready to tick; ``run`` plays it to the end."""

    def __init__(
        self,
        loaded: LoadedScenario,
        *,
        sinks: Sequence[Sink] = (),
        seed: int | None = None,
        autostart: bool = True,
        overrides: Mapping[str, str] | None = None,
        world: Body | None = None,
        sensors: SensorInputs | None = None,
    ) -> None:
        """``autostart=False`` leaves the scenario's activities selected but not started
        (a live session: the operator gets them ready and starts them). ``overrides``
        (``scenarios.loader.apply_overrides``) vary the scenario; recorded as ``variation``.
        ``world`` and ``sensors`` replace the simulated ones (a robot reached over ROS 2):
        then no pymunk world is built, only the pipeline (``build_pipeline``)."""
        built = build_pipeline(loaded, sinks=sinks, seed=seed, overrides=overrides)
        self.built = built
        scenario = self.scenario = built.scenario
        self.loaded, self.overrides, self.toolkit = loaded, built.overrides, built.toolkit
        self.registries: Registries = built.registries
        self.library, self.activity_names = built.library, list(built.scripts)
        assert built.tracker is not None, "a session's pipeline is tracked"
        self.tracker, self.sink = built.tracker, built.sink
        self.config, self.pipeline = built.config, built.pipeline
        self.tick_ms = scenario.tick_ms
        self.world = world or World(
            scenario, stream_rng(scenario.seed, "world"), behaviours=loaded.toolkit.behaviours
        )
        self.sensors = sensors or Sensors(
            scenario.sensors, scenario, stream_rng(scenario.seed, "sensors")
        )
        self.outputs = ActuatorOutputs()
        self.autostart = autostart
        self.schedule = self._schedule()
        self._lock = SafetyLock()
        """The scripted pad's safety lock (no heartbeat: only the operator releases it)."""
        self._command_id = 0

    # ------------------------------------------------------------------- set-up

    def _selection(self) -> list[tuple[str, dict[str, str]]]:
        selection = []
        for spec, path in zip(self.scenario.activities, self.loaded.activity_paths, strict=True):
            name = self.library.load(path).activityname if path is not None else spec.generator
            selection.append((name or "", dict(spec.options)))
        return selection

    def _schedule(self) -> dict[int, list[object]]:
        """Scenario events (and the automatic start) by the tick at which they fall due."""
        schedule: dict[int, list[object]] = {}

        def at(tick: int, item: object) -> None:
            schedule.setdefault(tick, []).append(item)

        for name, options in self._selection():
            at(0, OperatorEvent(at_s=0, command=Add(activity=name, options=options)))
        drives = any(
            isinstance(e, OperatorEvent) and isinstance(e.command, AUTO_START_COMMANDS)
            for e in self.scenario.events
        )
        if self.scenario.activities and self.autostart and not drives:
            at(0, OperatorEvent(at_s=0, command=GetReady()))
            at(1, OperatorEvent(at_s=0, command=Start()))
        for event in self.scenario.events:
            tick = self._tick_of(event.at_s)
            at(tick, event)
            if isinstance(event, JoystickEvent) and event.hold_s > 0:
                at(max(tick + 1, self._tick_of(event.at_s + event.hold_s)), JoystickEvent(at_s=0))
        return schedule

    def _tick_of(self, seconds: float) -> int:
        return round(seconds * 1000) // self.tick_ms

    # -------------------------------------------------------------------- ticking

    def step(
        self,
        tick: int,
        *,
        commands: Iterable[OperatorCommand] = (),
        joystick: JoystickInput | None = None,
    ) -> None:
        """One tick: world, sensors and due events, the pipeline, the world's state."""
        time_ms = tick * self.tick_ms
        self.world.step(self.outputs, tick=tick)
        scheduled: list[OperatorCommand] = []
        for event in self.schedule.pop(tick, ()):
            match event:
                case OperatorEvent():
                    scheduled.append(self.command(event.command))
                case JoystickEvent():
                    pad = event.pad
                    release = self._lock.receive(pad, now_s=time_ms / 1000)
                    joystick = pad.at(tick=tick, time_ms=time_ms, release=release)
                case TouchEvent():
                    self.sensors.touch(event, time_ms=time_ms)
                case FaultEvent():
                    self.sensors.fault(event)
                case BehaviourEvent():
                    self.world.apply_event(event)
        updates: list[MapUpdate] = self.sensors.sample(self.world, tick=tick, time_ms=time_ms)
        self.outputs = self.pipeline.tick(
            tick=tick,
            updates=updates,
            commands=[*scheduled, *commands] if commands else scheduled,
            joystick=joystick,
        )
        self.world.led, self.world.audio = self.outputs.led, self.outputs.audio
        self.sink.record(
            Topic.WORLD_STATE, time_ms * NS_PER_MS, self.world.state(tick=tick, time_ms=time_ms)
        )

    def late(self) -> None:
        """A tick is late (called from a live server's watchdog thread while the tick holds
        the main one): nothing to do for a simulated world, which waits for the tick; a
        session on a robot (``oimi bridge``) tells it to stand still."""

    def command(self, command: OperatorCommand) -> OperatorCommand:
        """``command`` numbered with the session's next id (a client's or a scenario's own
        id is not unique in the recording; the live server maps replies back)."""
        self._command_id += 1
        return msgspec.structs.replace(command, id=self._command_id)

    def run(
        self,
        *,
        progress: Callable[[int, int], None] | None = None,
        pace: Callable[[int], None] | None = None,
    ) -> RunResult:
        """Play every tick of the scenario; ``progress(tick, total)`` and ``pace(tick)`` are
        called after each tick (pace sleeps to the wall clock in ``--realtime`` mode).

        Ctrl-C stops the run between two ticks (``KeyboardInterrupt``), never inside one,
        so a recorder is never cut off in the middle of a write. A user's code that holds
        a tick is stopped by the :mod:`~.watchdog`."""
        total = self.scenario.ticks
        with interrupts_between_ticks() as checkpoint, watching() as watchdog:
            for tick in range(total):
                self.step(tick)
                watchdog.feed()
                if progress is not None:
                    progress(tick + 1, total)
                if pace is not None:
                    pace(tick)
                checkpoint()
        return self.result()

    def result(self) -> RunResult:
        t = self.tracker
        ticks = t.last_ms // self.tick_ms + 1
        summary = Summary(
            scenario=self.scenario.name,
            seed=self.scenario.seed,
            ticks=ticks,
            duration_s=ticks * self.tick_ms / 1000,  # each tick lasts tick_ms: 1500 are 30 s
            activities={a.name: a.state for a in self.pipeline.handler.activities()},
            goals_reached=dict(t.goals_reached),
            rules_fired=dict(sorted(t.episodes.fired().items())),
            min_distance_m={h: round(d, 4) for h, d in t.min_distance_m.items()},
            max_speed_mps=round(t.max_speed_mps, 4),
            contacts=t.contacts,
            rejected_inputs=len(t.rejections),
            safety_interventions=len(t.safety.episodes),
            protective_stops=sum(SafetyZone.STOP in e.zones for e in t.safety.episodes),
            min_surface_distance_m={h: round(d, 4) for h, d in t.proximity.closest_m.items()},
            contact_episodes=len(episodes := t.contact_episodes()),
            robot_initiated_contacts=sum(e.initiator == "robot" for e in episodes),
            pushed_contacts=sum(e.initiator == "pushed" for e in episodes),
            max_closing_speed_mps=max((e.closing_speed_mps for e in episodes), default=0.0),
            rule_episodes=dict(sorted(t.episodes.counts().items())),
            errors=tuple(t.errors),
            ran=t.ran(),
        )
        return RunResult(summary=summary, verdicts=tuple(t.verdicts()))

    # ------------------------------------------------------------------ recording

    def metadata(self) -> RecordingMetadata:
        """The recording's metadata: enough, with the attachments, to rebuild this run."""
        return self.built.metadata()

    def attachments(self) -> list[tuple[str, bytes]]:
        """The scenario file, the activity scripts, the rule library and the extensions'
        sources (``BuiltPipeline.attachments``)."""
        return self.built.attachments()


def library_scenarios() -> list[Path]:
    """The shipped scenario files, sorted by name."""
    return sorted(ACTIVITIES.parent.glob("*.toml"))
