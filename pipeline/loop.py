"""One tick of the robot's mind: the eight steps of section 4.2, wired stage to stage.

The loop owns no clock: the runner calls ``tick`` with the tick number and the
inputs that arrived (sensor updates, operator commands, joystick), and gets
back what the body must do. Every step's event goes to the sink it was given.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Final

import msgspec
from oimi.pipeline.act.actuator import Actuator, ActuatorStep
from oimi.pipeline.act.limits import RobotLimits, Velocity
from oimi.pipeline.act.safety import SafetySupervisor, Verdict
from oimi.pipeline.act.safety_config import SafetyConfig
from oimi.pipeline.errors import failure
from oimi.pipeline.events import (
    ActuatorCommands,
    Event,
    JoystickInput,
    Level,
    LogEntries,
    LogEntry,
    OperatorCommand,
    OperatorCommands,
    OperatorReply,
    ReaderProgress,
    RuleChainState,
    RuleDecisions,
    SafetyIntervention,
    SensorUpdates,
    Topic,
)
from oimi.pipeline.mapdeltas import MapDeltas
from oimi.pipeline.messages import (
    GENERATED_SOURCE,
    REGISTER_CAPACITY,
    ActuatorOutputs,
    MapUpdate,
    Message,
    RuleMessage,
    Script,
    WorldMap,
)
from oimi.pipeline.operator.handler import GeneratorHandler, PushScripts, StopActivities
from oimi.pipeline.registries import Registries
from oimi.pipeline.sense.producer import MapProducer
from oimi.pipeline.sink import NS_PER_MS, Sink
from oimi.pipeline.think.chain import RuleChain
from oimi.pipeline.think.mapparts import mistyped
from oimi.pipeline.think.reader import BlockReader, ReadOutcome, ScriptEntry, ScriptResolver

_SENSOR_UPDATES: Final = Topic.SENSOR_UPDATES
_RULE_DECISIONS: Final = Topic.RULE_DECISIONS
_MAP: Final = Topic.MAP
"""The topics of every tick the sensors move the map: a global each, not the enum class's
slow attribute path."""


class PipelineConfig(Message):
    """How the mind is set up; recorded with every session."""

    tick_ms: int = 20
    """Length of one tick of the simulated clock, ms (20 = 50 Hz)."""
    limits: RobotLimits = msgspec.field(default_factory=RobotLimits)
    register_capacity: int = REGISTER_CAPACITY
    script_root: str = "activities"
    """Folder (relative) inside which ``script_vect`` paths must resolve."""
    safety: SafetyConfig = msgspec.field(default_factory=SafetyConfig)
    """The safety supervisor's zones (always on; see ``pipeline.act.safety``)."""
    map_keyframe_ms: int = 5000
    """``/map`` writes the whole map (a keyframe) at its first message and then at the first
    change this long or more after the previous keyframe; deltas in between
    (``pipeline.mapdeltas``). 5 s: a reader seeking a tick decodes at most 5 s of deltas,
    and keyframes stay a small part of the recording."""


class Pipeline:
    """The Map Producer, rule chain, Block Reader, Actuator and Generator Handler, ticked."""

    def __init__(
        self,
        config: PipelineConfig,
        *,
        idle: ScriptEntry,
        resolve: ScriptResolver,
        handler: GeneratorHandler,
        sink: Sink,
        registries: Registries | None = None,
    ) -> None:
        """``registries``: the session's functions, rules and generators (the built-ins
        when omitted); the handler's catalogue should be built from the same."""
        self.config = config
        self.registries = registries = registries or Registries.build()
        self.map = WorldMap()
        self.producer = MapProducer(
            self.map, register_capacity=config.register_capacity, script_root=config.script_root
        )
        self.chain = RuleChain(registries.rules)
        self._resolve_file = resolve
        self.reader = BlockReader(
            self.map,
            idle=idle,
            resolve=self._resolve,
            register_capacity=config.register_capacity,
            functions=registries.functions,
        )
        self.actuator = Actuator(config.limits, tick_ms=config.tick_ms)
        self.safety = SafetySupervisor(config.safety, config.limits, tick_ms=config.tick_ms)
        self.handler = handler
        self.sink = sink
        self._started = False
        self._map_deltas = MapDeltas(keyframe_ms=config.map_keyframe_ms)
        self._last_place: tuple[str, str, str, str] = ("", "", "", "")
        self._last_operator = b""
        self._operator_moved = False
        """The handler was called this tick in a way that may have changed its state."""
        self._unreadable = ""
        """Why the safety supervisor could not read the map at the last tick (said once)."""

    def tick(
        self,
        *,
        tick: int,
        updates: Sequence[MapUpdate] = (),
        commands: Sequence[OperatorCommand] = (),
        joystick: JoystickInput | None = None,
    ) -> ActuatorOutputs:
        """Run the loop once at ``tick`` with this tick's inputs; return the body's command."""
        now_ms = tick * self.config.tick_ms
        emitter = _Emitter(self.sink, tick=tick, time_ms=now_ms)
        outcome = ReadOutcome()
        if not self._started:
            self._started = True
            start = self.reader.start(now_ms=now_ms)
            self._apply_chain(start, emitter)
            outcome.items += start.items

        # Inputs: sensor updates queue in the producer; operator and joystick act at once.
        # Before this tick's commands, so that "loading" lasts one tick.
        moved = self.handler.tick(now_ms)
        self._operator_moved = moved or bool(commands) or not self._last_operator
        if updates:
            emitter.emit(_SENSOR_UPDATES, SensorUpdates, updates=tuple(updates))
            for update in updates:
                rejection = self.producer.submit(update)
                if rejection is not None:
                    emitter.log(Level.WARNING, "producer", str(rejection), str(update.seq))
        if commands:
            emitter.emit(Topic.OPERATOR_COMMANDS, OperatorCommands, commands=tuple(commands))
            for command in commands:
                outcome.extend(self._operate(command, emitter, now_ms))
        if joystick is not None:
            self.sink.record(Topic.JOYSTICK, emitter.time_ns, joystick)
            self.actuator.joystick(joystick, now_ms=now_ms)

        # 1. Issue the block to the actuator (from the beginning when it changed).
        info = self.map.scriptinfo
        fresh = self.reader.take_new_block()
        self.actuator.issue(
            info.block,
            changed=info.changed or fresh,
            now_ms=now_ms,
            forced=info.changed and not fresh,
        )
        info.changed = False
        step = self.actuator.step(now_ms=now_ms)
        progress = self.actuator.progress
        moved_on = progress != (info.submove, info.subled, info.subaout)
        info.submove, info.subled, info.subaout = progress
        self._note_joystick(now_ms)
        if step.commands:
            emitter.emit(
                Topic.ACTUATOR_COMMANDS,
                ActuatorCommands,
                commands=step.commands,
                block=info.block if fresh or step.commands else None,
            )
        for text in (*step.clamps, *step.notes):
            emitter.log(Level.WARNING, "actuator", text, info.currentactivity)

        # 3. Pending update? Nothing new in the world or in the block's execution: stall.
        if not (
            self.producer.changes_pending
            or moved_on
            or step.done
            or step.commands
            or commands
            or joystick is not None
            or outcome.items
            or self.reader.fresh
            or info.overridecmd
            or info.restart
        ):
            if self.producer.pending:  # heartbeats alone: noted for the supervisor
                self.producer.consume(now_ms)
            self._publish_operator(emitter)
            return self._finish(step, emitter)

        # 4. Consume the pending updates into the map.
        for rejection in self.producer.consume(now_ms):
            emitter.log(Level.WARNING, "producer", str(rejection), str(rejection.update.seq))

        # 5-7. Compulsory switch, escape idle, read up to the next instruction block.
        outcome.extend(self.reader.sync_lifo(now_ms=now_ms))
        outcome.extend(self.reader.compulsory_switch(now_ms=now_ms))
        outcome.extend(self.reader.escape_idle(now_ms=now_ms))
        outcome.extend(self.reader.read(actuator_done=step.done, now_ms=now_ms))
        self._apply_chain(outcome, emitter)
        self._notify_handler(outcome)

        # 8. Propagate the map through the rule chain.
        decisions = self.chain.propagate(self.map, now_ms=now_ms)
        if decisions:
            emitter.emit(_RULE_DECISIONS, RuleDecisions, decisions=tuple(decisions))
        failures = self.chain.take_failures()
        if failures:  # rules that raised were removed: the chain changed
            emitter.logs.extend(failures)
            self._publish_chain((), emitter)
        notes = self.chain.take_notes()
        if notes:  # rules' messages to generators (thesis 3.2): delivered and logged
            self._operator_moved = True
            for line, note in zip(self.handler.deliver(notes), notes, strict=True):
                emitter.log(Level.INFO, "generators", line, note.generator)
            emitter.logs.extend(self.handler.take_failures())

        # 2. Publish progress (after this tick's reading, so it names the block in the works).
        self._publish_progress(outcome, emitter)
        self._publish_map(emitter)
        self._publish_operator(emitter)
        return self._finish(step, emitter)

    # ---------------------------------------------------------------- the steps' parts

    def _operate(self, command: OperatorCommand, emitter: _Emitter, now_ms: int) -> ReadOutcome:
        result = self.handler.handle(command, now_ms=now_ms, world_map=self.map)
        emitter.replies.append(result.reply)
        outcome = ReadOutcome()
        if not result.reply.ok:
            emitter.log(Level.WARNING, "operator", result.reply.reason, str(command.id))
        emitter.logs.extend(self.handler.take_failures())  # a generator's bug, said as such
        for effect in result.effects:
            match effect:
                case PushScripts():
                    self.reader.push(_generated(e.activity, e.script) for e in effect.lifo_order())
                case StopActivities():
                    outcome.extend(self.reader.stop_operator_activities(now_ms=now_ms))
        return outcome

    def _resolve(self, name: str) -> ScriptEntry | None:
        """A switch's target or a ``script_vect`` entry: a selected activity's generated
        script (``NAME``, or only that as ``generator:NAME``), else a script file."""
        activity = name.removeprefix(GENERATED_SOURCE)
        script = self.handler.generated(activity)
        if script is not None:
            return _generated(activity, script)
        return self._resolve_file(name) if activity == name else None

    def _apply_chain(self, outcome: ReadOutcome, emitter: _Emitter) -> None:
        emitter.logs.extend(outcome.logs)
        if not outcome.rule_messages and not outcome.unlock:
            return
        emitter.logs.extend(self.chain.apply(outcome.rule_messages))
        if outcome.unlock:
            self.chain.unlock()
        self._publish_chain(tuple(outcome.rule_messages), emitter)

    def _publish_chain(self, applied: tuple[RuleMessage, ...], emitter: _Emitter) -> None:
        active, held, removed = self.chain.names()
        emitter.emit(
            Topic.RULE_CHAIN,
            RuleChainState,
            applied=applied,
            active=active,
            held=held,
            removed=removed,
            locked=self.chain.locked,
        )

    def _notify_handler(self, outcome: ReadOutcome) -> None:
        for name, completed in outcome.finished:
            self._operator_moved |= self.handler.activity_finished(name, completed=completed)
        for name in outcome.started:
            self._operator_moved |= self.handler.activity_started(name)

    def _finish(self, step: ActuatorStep, emitter: _Emitter) -> ActuatorOutputs:
        """Supervise the tick's velocity, then write its logs and the supervisor's event."""
        outputs, event = self._supervise(step, emitter)
        emitter.flush_logs()
        if event is not None:
            self.sink.record(Topic.SAFETY, emitter.time_ns, event)
        return outputs

    def _supervise(
        self, step: ActuatorStep, emitter: _Emitter
    ) -> tuple[ActuatorOutputs, SafetyIntervention | None]:
        """The safety supervisor's pass over the body's velocity, on the map as the sensors
        alone made it (below every source of motion; no rule or script reaches it or that
        map). A map it cannot read (a fault: the wrong place is named in the log) stops it
        moving, turning on the spot aside, until it can again."""
        outputs, requested = step.outputs, self.actuator.velocity
        try:
            verdict, event = self.safety.supervise(
                requested,
                self.producer.perceived,
                heard=self.producer.heard,
                beats=self.producer.beats,
                tick=emitter.tick,
                now_ms=emitter.time_ms,
                source=self.actuator.motion_source,
            )
            self._unreadable = ""
        except Exception as error:  # never move on a map the supervisor cannot read
            wrong = mistyped(self.producer.perceived) or failure(error)
            text = f"cannot read the map ({wrong}): the robot is stopped"
            if text != self._unreadable:
                emitter.log(Level.ERROR, "safety", text)
            self._unreadable = text
            verdict, event = Verdict(Velocity(0.0, 0.0, requested.v_theta)), None
        if verdict.velocity == requested:
            return outputs, event
        self.actuator.hold(verdict.velocity)
        v_x, v_y, _ = verdict.velocity
        return msgspec.structs.replace(outputs, v_x=v_x, v_y=v_y, brake=True), event

    def _note_joystick(self, now_ms: int) -> None:
        status = self.map.robotstatus
        engaged = self.actuator.engaged
        if engaged and not status.joystick_engaged:
            status.joystick_engagedtime = now_ms
        status.joystick_engaged = engaged

    def _publish_progress(self, outcome: ReadOutcome, emitter: _Emitter) -> None:
        info = self.map.scriptinfo
        place = (info.currentactivity, info.goalid, info.actionid, info.blockid)
        if not outcome.items and place == self._last_place:
            return
        self._last_place = place
        emitter.emit(
            Topic.READER_PROGRESS,
            ReaderProgress,
            activity=place[0],
            goalid=place[1],
            actionid=place[2],
            blockid=place[3],
            items=tuple(outcome.items),
        )

    def _publish_map(self, emitter: _Emitter) -> None:
        delta = self._map_deltas.after(self.map, tick=emitter.tick, time_ms=emitter.time_ms)
        if delta is not None:
            self.sink.record(_MAP, emitter.time_ns, delta)

    def _publish_operator(self, emitter: _Emitter) -> None:
        if not self._operator_moved:
            return
        state = self.handler.state(
            tick=emitter.tick, time_ms=emitter.time_ms, replies=tuple(emitter.replies)
        )
        key = msgspec.json.encode((state.button, state.activities, state.replies))
        if key != self._last_operator:
            self._last_operator = key
            self.sink.record(Topic.OPERATOR_STATE, emitter.time_ns, state)


def _generated(activity: str, script: Script) -> ScriptEntry:
    """The reader's entry for an operator-selected activity's generated script."""
    return ScriptEntry(
        activity=activity, script=script, source=GENERATED_SOURCE + activity, operator=True
    )


class _Emitter:
    """Stamps a tick's events with its tick and time, and gathers its log entries."""

    def __init__(self, sink: Sink, *, tick: int, time_ms: int) -> None:
        self.sink = sink
        self.tick = tick
        self.time_ms = time_ms
        self.time_ns = time_ms * NS_PER_MS
        self.logs: list[LogEntry] = []
        self.replies: list[OperatorReply] = []
        """The replies to this tick's operator commands, for ``/operator/state``."""

    def emit(self, topic: Topic, kind: type[Event], **fields: object) -> None:
        self.sink.record(topic, self.time_ns, kind(tick=self.tick, time_ms=self.time_ms, **fields))

    def log(self, level: Level, source: str, message: str, ref: str = "") -> None:
        self.logs.append(LogEntry(level=level, source=source, message=message, ref=ref))

    def flush_logs(self) -> None:
        if self.logs:
            self.emit(Topic.LOG, LogEntries, entries=tuple(self.logs))
