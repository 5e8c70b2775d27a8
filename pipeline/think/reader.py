"""The Block Reader: a LIFO of scripts over an ever-present idle activity (sections 3.2, 4.2).

The reader walks goals > actions > blocks in order, executes jumps, terminus and
sensor blocks itself, and stops on the next instruction block, which it puts in
the map for the actuator. Loading a script yields its alfa messages; ending it
yields its omega messages; the loop hands both to the rule chain.

The LIFO is mirrored in ``map.scriptinfo.script_vect`` (last = top): a
``script_vect`` update or a rule that changes it changes what runs next.

Goals: a goal is *reached* when its last action finishes in order, when a jump
goes on to the first block of the next goal, or when a terminus ends the script
inside it. A goal left by any other jump into another goal is not reached; if the
script then completes without reaching it, it is *failed*. A goal cut short by a
rule-forced switch or the operator is *interrupted*; a switched-out script waits in
the LIFO and resumes from the start of the goal it was in.

A rule-forced switch (``overridecmd``) names an activity: the idle activity, what the
resolver finds (a selected generator's last script, a script file) or a script the reader
was given before under that name. Naming the running activity only moves the reader to
goal/action/block, like a jump: no suspended copy, no omega or alfa messages.

Long module: the Block Reader is one state machine (LIFO, goals, actions, blocks,
switches) over one set of fields; its helpers already live in their own modules.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Final

import msgspec
from oimi.pipeline.errors import FAILURES, failure
from oimi.pipeline.events import Level, LogEntry, ProgressItem, ProgressKind
from oimi.pipeline.messages import (
    REGISTER_CAPACITY,
    ActivityStatus,
    ActivityTracking,
    GoalEvent,
    GoalStatus,
    GoalTracking,
    InstructionBlock,
    JumpBlock,
    Message,
    RuleMessage,
    Script,
    SensorBlock,
    TerminusBlock,
    WorldMap,
)
from oimi.pipeline.think.conditions import Condition, compile_condition
from oimi.pipeline.think.errors import RuleSyntaxError
from oimi.pipeline.think.functions import FunctionRegistry
from oimi.pipeline.think.stdlib import default_registry

MAX_BLOCKS_PER_READ: Final = 1000
"""Blocks read in one pass before the reader calls the script a runaway loop and ends it."""

Position = tuple[int, int, int]


class ScriptEntry(Message):
    """A script waiting in (or taken from) the LIFO."""

    activity: str
    """The name the operator and the map know it by."""
    script: Script
    source: str
    """Where it came from (a path under the activities folder, or ``generator:NAME``)."""
    start: Position = (0, 0, 0)
    """Where to start reading: goal, action and block index."""
    operator: bool = False
    """Pushed by the Generator Handler (an operator-selected activity)."""


ScriptResolver = Callable[[str], ScriptEntry | None]
"""Finds a script by activity name or source path; supplied by the edge."""


class ReadOutcome:
    """What one of the reader's steps did, for the loop to pass on."""

    def __init__(self) -> None:
        self.items: list[ProgressItem] = []
        self.rule_messages: list[RuleMessage] = []
        self.logs: list[LogEntry] = []
        self.started: list[str] = []
        self.finished: list[tuple[str, bool]] = []
        self.unlock = False
        """A script with no alfa messages was loaded: the chain must not stay locked."""

    def extend(self, other: ReadOutcome) -> None:
        self.items += other.items
        self.rule_messages += other.rule_messages
        self.logs += other.logs
        self.started += other.started
        self.finished += other.finished
        self.unlock = self.unlock or other.unlock


def path_of(position: Position) -> str:
    goal, action, block = position
    return f"goal{goal}/act{action}/blk{block}"


def parse_path(text: str) -> Position:
    """``goalX/actY/blkZ`` as indices; ``ValueError`` when malformed."""
    parts = text.split("/")
    prefixes = ("goal", "act", "blk")
    if len(parts) != 3 or not all(p.startswith(x) for p, x in zip(parts, prefixes, strict=True)):
        raise ValueError(f"{text!r} is not a goalX/actY/blkZ path")
    goal, action, block = (int(p[len(x) :]) for p, x in zip(parts, prefixes, strict=True))
    return goal, action, block


def block_at(script: Script, position: Position):
    goal, action, block = position
    try:
        return script.goals[goal].actions[action].blocks[block]
    except IndexError:
        return None


class BlockReader:
    """Reads the current script block by block; owns the LIFO and the idle activity."""

    def __init__(
        self,
        world_map: WorldMap,
        *,
        idle: ScriptEntry,
        resolve: ScriptResolver,
        register_capacity: int = REGISTER_CAPACITY,
        functions: FunctionRegistry | None = None,
    ) -> None:
        """``functions``: what jump conditions may call (the standard library when omitted)."""
        self.map = world_map
        self.functions = functions or default_registry()
        self.idle = idle
        self.resolve = resolve
        self.capacity = register_capacity
        self.lifo: list[ScriptEntry] = []
        self.current = idle
        self.position: Position = idle.start
        self.fresh = False
        """A script was just loaded: read from ``position`` inclusive, done or not."""
        self.new_block = False
        """A new instruction block was put in the map since the loop last issued one."""
        self._conditions: dict[str, Condition] = {}
        self._abandoned: set[int] = set()
        """Goals of the current script left by a jump (membership only, never iterated)."""
        self.known: dict[str, ScriptEntry] = {}
        """Every script given to the reader (pushed or loaded), by activity name, the latest
        kept: what a rule-forced switch can reach besides the resolver's files."""

    # ----------------------------------------------------------------- public steps

    def start(self, *, now_ms: int) -> ReadOutcome:
        """Load the idle activity; call once before the first tick."""
        return self._load(self.idle, now_ms=now_ms)

    @property
    def is_idle(self) -> bool:
        return self._is_idle_entry(self.current)

    def push(self, entries: Iterable[ScriptEntry]) -> None:
        """Put scripts on the LIFO; the last one given ends on top and runs first."""
        entries = list(entries)
        self.lifo.extend(entries)
        self.known.update((e.activity, e) for e in entries)
        self._mirror()

    def sync_lifo(self, *, now_ms: int) -> ReadOutcome:
        """Follow a change of ``script_vect`` made by an update or a rule (before step 5)."""
        outcome = ReadOutcome()
        wanted = self.map.scriptinfo.script_vect
        if wanted != [e.source for e in self.lifo]:
            spare = list(self.lifo)
            rebuilt: list[ScriptEntry] = []
            for source in wanted:
                entry = next((e for e in spare if e.source == source), None) or self.resolve(source)
                if entry is None:
                    outcome.logs.append(
                        _warn(f"script_vect: no script {source!r}; skipped", source)
                    )
                    continue
                if entry in spare:
                    spare.remove(entry)
                rebuilt.append(entry)
            self.lifo = rebuilt
            self._mirror()
        if self.map.scriptinfo.restart:
            self.map.scriptinfo.restart = False
            outcome.extend(self._end_current(ProgressKind.END, completed=False, now_ms=now_ms))
            outcome.extend(self._load(self._pop(), now_ms=now_ms))
        return outcome

    def compulsory_switch(self, *, now_ms: int) -> ReadOutcome:
        """Loop step 5: a rule raised ``overridecmd``; load the named script where it says."""
        info = self.map.scriptinfo
        outcome = ReadOutcome()
        if not info.overridecmd:
            return outcome
        info.overridecmd = False
        target = info.currentactivity
        entry = self._find(target)
        try:
            start = parse_path(f"{info.goalid}/{info.actionid}/{info.blockid}")
        except ValueError as error:
            entry, reason = None, str(error)
        else:
            reason = f"no script {target!r}"
            if entry is not None and block_at(entry.script, start) is None:
                entry, reason = None, f"{target!r} has no block {path_of(start)}"
        if entry is None:
            info.currentactivity = self.current.activity
            outcome.logs.append(_warn(f"compulsory switch refused: {reason}", target))
            return outcome
        outcome.items.append(
            self._item(ProgressKind.SWITCH, detail=f"to {target} {path_of(start)}")
        )
        if target == self.current.activity:
            # Inside the running script: a move like a jump; it is not loaded again.
            self._leave_goal(start, outcome, now_ms)
            self.position, self.fresh = start, True
            return outcome
        interrupted = self.current
        # Suspended, not finished: it waits in the LIFO and resumes at the goal it was in.
        suspend = not self.is_idle and entry is not self.idle
        outcome.extend(
            self._end_current(
                ProgressKind.SWITCH, completed=False, now_ms=now_ms, finished=not suspend
            )
        )
        if suspend:
            self.lifo.append(msgspec.structs.replace(interrupted, start=(self.position[0], 0, 0)))
            self._mirror()
        outcome.extend(
            self._load(
                msgspec.structs.replace(entry, start=start),
                now_ms=now_ms,
            )
        )
        return outcome

    def escape_idle(self, *, now_ms: int) -> ReadOutcome:
        """Loop step 6: while idle, a non-idle script on top of the LIFO is loaded."""
        if not self.is_idle or not self.lifo:
            return ReadOutcome()
        outcome = self._end_current(ProgressKind.END, completed=False, now_ms=now_ms, quiet=True)
        outcome.extend(self._load(self._pop(), now_ms=now_ms))
        return outcome

    def stop_operator_activities(self, *, now_ms: int) -> ReadOutcome:
        """The operator pressed Stop: drop the operator's scripts and go back to idle."""
        self.lifo = [e for e in self.lifo if not e.operator]
        self._mirror()
        if not self.current.operator:
            return ReadOutcome()
        outcome = self._end_current(ProgressKind.END, completed=False, now_ms=now_ms)
        outcome.extend(self._load(self._pop(), now_ms=now_ms))
        return outcome

    def read(self, *, actuator_done: bool, now_ms: int) -> ReadOutcome:
        """Loop step 7: when the current block is consumed, read on to the next instruction."""
        outcome = ReadOutcome()
        if not (self.fresh or actuator_done):
            return outcome
        position = self.position if self.fresh else self._after(self.position, outcome, now_ms)
        self.fresh = False
        for _ in range(MAX_BLOCKS_PER_READ):
            if position is None:
                outcome.extend(self._end_current(ProgressKind.END, completed=True, now_ms=now_ms))
                outcome.extend(self._load(self._pop(), now_ms=now_ms))
                position, self.fresh = self.position, False
                continue
            self.position = position
            block = block_at(self.current.script, position)
            match block:
                case InstructionBlock():
                    self._show(block)
                    outcome.items.append(self._item(ProgressKind.BLOCK))
                    return outcome
                case JumpBlock():
                    position = self._jump(block, outcome, now_ms)
                case TerminusBlock():
                    outcome.items.append(self._item(ProgressKind.TERMINUS))
                    position = None
                case SensorBlock():
                    outcome.items.append(self._item(ProgressKind.SENSOR, detail=block.request))
                    position = self._after(position, outcome, now_ms)
                case _:
                    position = self._after(position, outcome, now_ms)
        outcome.logs.append(
            LogEntry(
                level=Level.ERROR,
                source="reader",
                ref=self.current.activity,
                message=f"{self.current.activity}: {MAX_BLOCKS_PER_READ} blocks read without an "
                "instruction block (a jump loop?); the script is ended",
            )
        )
        self._set_goal(
            self.position[0], GoalStatus.FAILED, now_ms, ProgressKind.GOAL_FAILED, outcome
        )
        outcome.extend(self._end_current(ProgressKind.END, completed=False, now_ms=now_ms))
        outcome.extend(self._load(self._pop(), now_ms=now_ms))
        return outcome

    def take_new_block(self) -> bool:
        """Whether a new block was read since the last call (the loop issues it as new)."""
        new, self.new_block = self.new_block, False
        return new

    # ------------------------------------------------------------------- internals

    def _is_idle_entry(self, entry: ScriptEntry) -> bool:
        return entry.activity == self.idle.activity

    def _find(self, activity: str) -> ScriptEntry | None:
        """The script a switch to ``activity`` loads: idle, the resolver's (a generator's last
        script or a file), else the last one given to the reader under that name."""
        if activity == self.idle.activity:
            return self.idle
        return self.resolve(activity) or self.known.get(activity)

    def _pop(self) -> ScriptEntry:
        entry = self.lifo.pop() if self.lifo else self.idle
        self._mirror()
        return entry

    def _mirror(self) -> None:
        self.map.scriptinfo.script_vect = [e.source for e in self.lifo]

    def _item(self, kind: ProgressKind, detail: str = "") -> ProgressItem:
        return ProgressItem(
            kind=kind, activity=self.current.activity, path=path_of(self.position), detail=detail
        )

    def _show(self, block: InstructionBlock) -> None:
        info = self.map.scriptinfo
        goal, action, index = self.position
        info.goalid, info.actionid, info.blockid = f"goal{goal}", f"act{action}", f"blk{index}"
        info.goalname = self.current.script.goals[goal].goalid
        info.block = block
        info.submove = info.subled = info.subaout = 0
        self.new_block = True
        self._set_goal(goal, GoalStatus.ACTIVE, None, None, None)

    def _load(self, entry: ScriptEntry, *, now_ms: int) -> ReadOutcome:
        outcome = ReadOutcome()
        problem = self._check_conditions(entry.script)
        if problem:
            outcome.logs.append(
                LogEntry(
                    level=Level.ERROR,
                    source="reader",
                    ref=entry.activity,
                    message=f"{entry.activity}: not loaded: {problem}",
                )
            )
            outcome.finished.append((entry.activity, False))
            if entry is self.idle:
                raise ValueError(f"the idle activity cannot run: {problem}")
            outcome.extend(self._load(self._pop(), now_ms=now_ms))
            return outcome
        self.current = entry
        if not self._is_idle_entry(entry):
            self.known[entry.activity] = entry
        self.position = entry.start
        self.fresh = True
        self._abandoned = set()
        info = self.map.scriptinfo
        info.currentactivity = entry.activity
        info.scriptpath = entry.source
        info.block = None
        tracking = self._tracking(entry, now_ms)
        tracking.status = ActivityStatus.RUNNING
        for goal in tracking.goals[entry.start[0] :]:
            goal.status, goal.changetime = GoalStatus.PENDING, now_ms
        outcome.rule_messages += entry.script.alfarulemessages
        outcome.unlock = not entry.script.alfarulemessages
        outcome.started.append(entry.activity)
        outcome.items.append(
            self._item(
                ProgressKind.IDLE if self.is_idle else ProgressKind.LOAD, detail=entry.source
            )
        )
        return outcome

    def _end_current(
        self,
        kind: ProgressKind,
        *,
        completed: bool,
        now_ms: int,
        quiet: bool = False,
        finished: bool = True,
    ) -> ReadOutcome:
        """Unload the current script: goals, tracking, omega messages, scope-U bindings.
        ``quiet`` adds no progress item; ``finished=False`` (a suspension) does not tell the
        handler the activity finished."""
        outcome = ReadOutcome()
        entry = self.current
        tracking = self._tracking(entry, now_ms)
        goal = self.position[0]
        if completed:
            self._set_goal(goal, GoalStatus.REACHED, now_ms, ProgressKind.GOAL_REACHED, outcome)
            for index, record in enumerate(tracking.goals):
                if index in self._abandoned and record.status != GoalStatus.REACHED:
                    self._set_goal(
                        index, GoalStatus.FAILED, now_ms, ProgressKind.GOAL_FAILED, outcome
                    )
        elif (
            not self._is_idle_entry(entry)
            and goal < len(tracking.goals)
            and (tracking.goals[goal].status == GoalStatus.ACTIVE)
        ):
            self._set_goal(
                goal, GoalStatus.INTERRUPTED, now_ms, ProgressKind.GOAL_INTERRUPTED, outcome
            )
        tracking.status = ActivityStatus.COMPLETED if completed else ActivityStatus.INTERRUPTED
        outcome.rule_messages += entry.script.omegarulemessages
        if not quiet:
            outcome.items.append(
                self._item(kind, detail="completed" if completed else "interrupted")
            )
        if finished:
            outcome.finished.append((entry.activity, completed))
        self.map.aliases.clear()
        self.map.variables.clear()
        self.map.scriptinfo.block = None
        return outcome

    def _tracking(self, entry: ScriptEntry, now_ms: int) -> ActivityTracking:
        activities = self.map.robotstatus.activities
        found = next((a for a in activities if a.activityname == entry.activity), None)
        if found is None:
            found = ActivityTracking(
                activityname=entry.activity,
                creationtime=now_ms,
                goals=[
                    GoalTracking(goalid=g.goalid, changetime=now_ms) for g in entry.script.goals
                ],
            )
            activities.append(found)
        return found

    def _set_goal(
        self,
        goal: int,
        status: GoalStatus,
        now_ms: int | None,
        kind: ProgressKind | None,
        outcome: ReadOutcome | None,
    ) -> None:
        tracking = self._tracking(self.current, now_ms or 0)
        if goal >= len(tracking.goals) or tracking.goals[goal].status == status:
            return
        record = tracking.goals[goal]
        record.status = status
        if now_ms is None or kind is None or outcome is None:
            return
        record.changetime = now_ms
        register = {
            GoalStatus.REACHED: self.map.robotstatus.goalreached,
            GoalStatus.FAILED: self.map.robotstatus.goalfailed,
            GoalStatus.INTERRUPTED: self.map.robotstatus.goalinterrupted,
        }[status]
        register.append(GoalEvent(goalid=record.goalid, timestamp=now_ms))
        self.map.robotstatus.mark_set(f"goal{status.value}")
        del register[: max(0, len(register) - self.capacity)]
        outcome.items.append(
            ProgressItem(
                kind=kind, activity=self.current.activity, path=f"goal{goal}", detail=record.goalid
            )
        )

    def _after(self, position: Position, outcome: ReadOutcome, now_ms: int) -> Position | None:
        """The next block in reading order; leaving a goal marks it reached."""
        goal, action, block = position
        goals = self.current.script.goals
        if block + 1 < len(goals[goal].actions[action].blocks):
            return goal, action, block + 1
        for a in range(action + 1, len(goals[goal].actions)):
            if goals[goal].actions[a].blocks:
                return goal, a, 0
        self._set_goal(goal, GoalStatus.REACHED, now_ms, ProgressKind.GOAL_REACHED, outcome)
        for g in range(goal + 1, len(goals)):
            for a, act in enumerate(goals[g].actions):
                if act.blocks:
                    return g, a, 0
        return None

    def _jump(self, block: JumpBlock, outcome: ReadOutcome, now_ms: int) -> Position | None:
        try:
            holds = self._conditions[block.toparse].evaluate(self.map, now_ms=now_ms).result
        except FAILURES as error:  # a user's function: the script goes on, as if false
            holds = False
            where = f"{self.current.activity}/{path_of(self.position)}"
            outcome.logs.append(
                LogEntry(
                    level=Level.ERROR,
                    source="reader",
                    message=f"{where}: the jump condition raised {failure(error)}; taken as false",
                    ref=self.current.activity,
                )
            )
        target = block.truejump if holds else block.falsejump
        outcome.items.append(self._item(ProgressKind.JUMP, detail=f"{holds} -> {target or 'next'}"))
        if not target:
            return self._after(self.position, outcome, now_ms)
        position = parse_path(target)
        self._leave_goal(position, outcome, now_ms)
        return position

    def _leave_goal(self, position: Position, outcome: ReadOutcome, now_ms: int) -> None:
        """Going to ``position`` in the same script: the goal left is reached or abandoned."""
        goal = self.position[0]
        if position == (goal + 1, 0, 0):
            # Straight on to the next goal: the same as finishing this one.
            self._set_goal(goal, GoalStatus.REACHED, now_ms, ProgressKind.GOAL_REACHED, outcome)
        elif position[0] != goal:
            # Left elsewhere: not reached; failed if the script ends without reaching it.
            self._set_goal(goal, GoalStatus.PENDING, None, None, None)
            self._abandoned.add(goal)

    def _check_conditions(self, script: Script) -> str:
        """Compile every jump condition and check every target once, when a script loads."""
        for g, goal in enumerate(script.goals):
            for a, action in enumerate(goal.actions):
                for b, block in enumerate(action.blocks):
                    if not isinstance(block, JumpBlock):
                        continue
                    where = path_of((g, a, b))
                    for target in (block.truejump, block.falsejump):
                        if target and (
                            _safe_parse(target) is None
                            or block_at(script, _safe_parse(target)) is None
                        ):
                            return f"{where}: jump to {target!r}, which does not exist"
                    if block.toparse not in self._conditions:
                        try:
                            self._conditions[block.toparse] = compile_condition(
                                block.toparse, registry=self.functions
                            )
                        except RuleSyntaxError as error:
                            return f"{where}: bad condition: {error}"
        return ""


def _safe_parse(text: str) -> Position | None:
    try:
        return parse_path(text)
    except ValueError:
        return None


def _warn(message: str, ref: str) -> LogEntry:
    return LogEntry(level=Level.WARNING, source="reader", message=message, ref=ref)
