"""What a live session's clients see: a sink that keeps the latest of each topic.

:class:`LiveView` is added to the session's sinks; after each tick the server
asks it for the replies to the tick's commands, the console's state (from the
Generator Handler itself, the one command layer) and a frame of the live view.
"""

from __future__ import annotations

from collections import deque
from typing import Final

from oimi.live.protocol import Block, SessionState, WorldMessage
from oimi.pipeline.events import (
    ActivityEntry,
    ActivityState,
    Event,
    Level,
    LogEntries,
    LogEntry,
    OperatorReply,
    OperatorState,
    ReaderProgress,
    RuleDecisions,
    SafetyIntervention,
    SafetyPhase,
    Topic,
    WorldState,
)
from oimi.pipeline.operator.handler import GeneratorHandler

FIRED_WINDOW_MS: Final = 1000
"""A rule stays in the live view's "firing" list this long after its condition held."""

LOG_LINES: Final = 8


class LiveView:
    """A sink keeping the latest world state, block, rules fired, log lines, safety episode
    and replies."""

    def __init__(self, handler: GeneratorHandler) -> None:
        self.handler = handler
        self.tick = 0
        self.time_ms = 0
        self.world: WorldState | None = None
        self.block = Block()
        self.replies: dict[int, OperatorReply] = {}
        """Replies to operator commands by command id; the server takes them after each tick."""
        self._fired: dict[str, int] = {}
        self._log: deque[LogEntry] = deque(maxlen=LOG_LINES)
        self.safety: SafetyIntervention | None = None
        """The supervisor's episode under way (None: it limits nothing)."""

    def record(self, topic: Topic, time_ns: int, message: Event) -> None:
        del time_ns
        self.tick, self.time_ms = message.tick, message.time_ms
        match message:
            case OperatorState():
                for reply in message.replies:
                    self.replies[reply.id] = reply
            case ReaderProgress():
                self.block = Block(
                    activity=message.activity,
                    goal=message.goalid,
                    action=message.actionid,
                    block=message.blockid,
                )
            case RuleDecisions():
                for decision in message.decisions:
                    if decision.fired:
                        self._fired[decision.rule] = message.time_ms
            case WorldState():
                self.world = message
            case LogEntries():
                self._log.extend(e for e in message.entries if e.level >= Level.WARNING)
            case SafetyIntervention():
                self.safety = None if message.phase is SafetyPhase.END else message

    def take_replies(self) -> dict[int, OperatorReply]:
        replies, self.replies = self.replies, {}
        return replies

    def note(self, entry: LogEntry) -> None:
        """A line from the server itself (the dead-man released the lock...)."""
        self._log.append(entry)

    def state(self) -> SessionState:
        """The console's activity screen now."""
        activities = self.handler.activities()
        return SessionState(
            tick=self.tick,
            time_ms=self.time_ms,
            button=self.handler.button.value,
            activities=activities,
            block=self.block,
            paused_by=self._paused_by(activities),
        )

    def _paused_by(self, activities: tuple[ActivityEntry, ...]) -> str:
        """The script running instead of the current activity ("": none is, or it runs)."""
        running = self.block.activity
        current = next((a.name for a in activities if a.state is ActivityState.CURRENT), None)
        if current is None or not running or self.handler.running(running) == current:
            return ""
        return running

    def frame(self, *, joystick_engaged: bool, released: str = "") -> WorldMessage | None:
        """The live view now (None before the first tick)."""
        world = self.world
        if world is None:
            return None
        since = self.time_ms - FIRED_WINDOW_MS
        return WorldMessage(
            tick=world.tick,
            time_ms=world.time_ms,
            robot=world.robot,
            humans=world.humans,
            objects=world.objects,
            led=world.led,
            audio=world.audio,
            block=self.block,
            fired=tuple(sorted(r for r, at in self._fired.items() if at > since)),
            log=tuple(self._log),
            joystick_engaged=joystick_engaged,
            released="" if joystick_engaged else released,
            safety=self.safety,
        )
