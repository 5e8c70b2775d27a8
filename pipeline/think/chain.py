"""The daisy chain of rules the map passes through each tick, changed by alfa/omega messages.

A rule is in exactly one state: active, held or removed (or absent: never loaded).
Actions (``RuleAction``): A activates and adds an absent or removed rule; D creates
one but holds it for later; R removes an active or held rule (kept aside so that C
can recover it); B brings a held rule back; C recovers a removed rule (creating it
when it was never loaded, as the thesis's idle activity does with ``kick_starter``).
A message that does not fit the rule's state changes nothing and is reported with
the reason on ``/log``: at INFO when the rule is already where the message would put it
(R on a removed rule, C on an active one), else at WARNING.

Mutex commands (``MutexCmd``): L locks the map's propagation before the message,
U unlocks it after; while locked, the map does not pass through the rules.
"""

from __future__ import annotations

from collections.abc import Iterable

from oimi.pipeline.errors import FAILURES, failure
from oimi.pipeline.events import Level, LogEntry, RuleDecision
from oimi.pipeline.messages import GeneratorNote, MutexCmd, RuleAction, RuleMessage, WorldMap
from oimi.pipeline.think.errors import RuleSyntaxError
from oimi.pipeline.think.rules import Rule, RuleContext, RuleRegistry


class RuleChain:
    """Active rules in order, held (delayed) and removed ones, and the propagation lock."""

    def __init__(self, registry: RuleRegistry, *, shortcuts: bool = True) -> None:
        """``shortcuts``: skip rules that would find what they read unchanged, and compare
        only the parts of the map a body declares it writes (the decisions are the same
        either way; off for comparisons)."""
        self.registry = registry
        self.shortcuts = shortcuts
        self.notes: list[GeneratorNote] = []
        self.active: list[Rule] = []
        self.held: dict[str, Rule] = {}
        self.removed: dict[str, Rule] = {}
        self.locked = False
        self.failures: list[LogEntry] = []

    def apply(self, messages: Iterable[RuleMessage]) -> list[LogEntry]:
        """Apply alfa/omega messages in order; what cannot be applied is reported, not raised."""
        problems: list[LogEntry] = []
        for message in messages:
            if message.mutexcmd == MutexCmd.L:
                self.locked = True
            problem = self._apply_one(message)
            if problem:
                level, text = problem if isinstance(problem, tuple) else (Level.WARNING, problem)
                problems.append(LogEntry(level=level, source="rules", message=text, ref=message.id))
            if message.mutexcmd == MutexCmd.U:
                self.locked = False
        return problems

    def unlock(self) -> None:
        """Let the map propagate again (used when a script with no alfa messages loads)."""
        self.locked = False

    def propagate(self, world_map: WorldMap, *, now_ms: int) -> list[RuleDecision]:
        """Pass the map through every active rule in order; nothing happens while locked.

        A rule whose condition or body raises is removed (as by an R message: a C message
        brings it back) and reported in :meth:`take_failures`; what its body changed before
        it raised stays in the map, and the map goes on to the next rule."""
        if self.locked:
            return []
        ctx = RuleContext(now_ms=now_ms, shortcuts=self.shortcuts)
        decisions = []
        for rule in list(self.active):
            try:
                decisions.append(rule.decide(world_map, ctx))
            except FAILURES as error:  # a user's rule or function: the session goes on
                self._fail(rule, error, ctx)
        self.notes += ctx.notes
        return decisions

    def take_failures(self) -> list[LogEntry]:
        """The rules removed for raising since the last call, one ERROR entry each."""
        failures, self.failures = self.failures, []
        return failures

    def take_notes(self) -> list[GeneratorNote]:
        """The rules' messages to generators since the last call, in the order written."""
        notes, self.notes = self.notes, []
        return notes

    def names(self) -> tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...]]:
        """The ids of the active, held and removed rules (active in chain order)."""
        return (
            tuple(rule.name for rule in self.active),
            tuple(self.held),
            tuple(self.removed),
        )

    def state(self, name: str) -> str:
        """``active``, ``held``, ``removed`` or ``absent`` (never loaded): one at a time."""
        if self._find_active(name):
            return "active"
        if name in self.held:
            return "held"
        return "removed" if name in self.removed else "absent"

    def _fail(self, rule: Rule, error: BaseException, ctx: RuleContext) -> None:
        self.active.remove(rule)
        self.removed[rule.name] = rule
        ctx.stores = None  # its condition may have bound some before it raised
        if ctx.parts is not None:  # the body may have changed the map before it raised
            ctx.parts.forget()
            ctx.parts.baseline = None
        text = f"rule {rule.name!r} (code {rule.rulecode}) raised {failure(error)}; removed"
        self.failures.append(
            LogEntry(level=Level.ERROR, source="rules", message=text, ref=rule.name)
        )

    def _find_active(self, name: str) -> Rule | None:
        return next((rule for rule in self.active if rule.name == name), None)

    def _create(self, message: RuleMessage) -> Rule | str | tuple[Level, str]:
        """A new rule, or why not (an ERROR when a user's rule class raised creating it)."""
        if message.rulecode not in self.registry:
            return f"unknown rule code {message.rulecode} for rule {message.id!r}"
        try:
            return self.registry.create(message)
        except RuleSyntaxError as error:
            return f"rule {message.id!r} has a bad condition: {error}"
        except FAILURES as error:  # a user's rule class: the session goes on without it
            what = f"rule {message.id!r} (code {message.rulecode}) could not be created"
            return Level.ERROR, f"{what}: {failure(error)}"

    def _apply_one(self, message: RuleMessage) -> str | tuple[Level, str] | None:
        """Move one rule between states; why not, when the action does not apply to its state.

        R on a removed rule and C on an active one are harmless (the thesis's example_act
        removes kick_starter after the idle activity's omega did): reported at INFO."""
        name, action = message.id, message.action
        state = self.state(name)
        if action in (RuleAction.A, RuleAction.D):
            if state in ("active", "held"):
                return f"{action.name}: rule {name!r} is loaded already ({state})"
            rule = self._create(message)
            if not isinstance(rule, Rule):
                return rule
            self.removed.pop(name, None)
            if action == RuleAction.A:
                self.active.append(rule)
            else:
                self.held[name] = rule
            return None
        if action == RuleAction.R:
            if state == "active":
                rule = self._find_active(name)
                self.active.remove(rule)  # type: ignore[arg-type]
                self.removed[name] = rule  # type: ignore[assignment]
            elif state == "held":
                self.removed[name] = self.held.pop(name)
            elif state == "removed":
                return Level.INFO, f"R: rule {name!r} is already removed"
            else:
                return f"R: rule {name!r} is not loaded"
            return None
        if action == RuleAction.B:
            if state != "held":
                return f"B: rule {name!r} is {state}, not held"
            self.active.append(self.held.pop(name))
            return None
        # RuleAction.C: recover a removed rule, or create one never loaded (listing 4.1).
        if state == "removed":
            self.active.append(self.removed.pop(name))
            return None
        if state == "active":
            return Level.INFO, f"C: rule {name!r} is already active, not removed"
        if state != "absent":
            return f"C: rule {name!r} is {state}, not removed"
        rule = self._create(message)
        if not isinstance(rule, Rule):
            return rule
        self.active.append(rule)
        return None
