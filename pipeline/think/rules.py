"""Rules: a condition in the rule language and a body that may change the map (section 4.3).

A rule class is listed in a session's :class:`RuleRegistry` under its ``rulecode``;
alfa/omega messages name the code, and the chain instantiates the class with the
message's id and topics.
"""

from __future__ import annotations

import enum
import hashlib
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import msgspec
from oimi.pipeline.events import MapChange, RuleDecision
from oimi.pipeline.jsontree import ABSENT, differences
from oimi.pipeline.messages import GeneratorNote, RuleMessage, WorldMap
from oimi.pipeline.think.conditions import Condition, Evaluation, compile_condition
from oimi.pipeline.think.errors import RuleSyntaxError
from oimi.pipeline.think.functions import FunctionRegistry

MAX_CHANGE_TEXT = 120
"""Longest value text kept in a decision's diff; longer values are cut with an ellipsis."""


@dataclass
class RuleContext:
    """What a rule body may read besides the map: the clock and the scripts it can switch to."""

    now_ms: int
    tick_scope: dict[str, str] = field(default_factory=dict)
    snapshot: bytes | None = None
    """The map's JSON as the last fired rule left it (saves encoding it again); reset when
    a condition binds scope-U aliases or variables, so a body's diff is its own."""
    notes: list[GeneratorNote] = field(default_factory=list)
    """Messages the rules wrote to script generators this tick (delivered by the loop)."""


class Effect(enum.Enum):
    """What a rule body says it did to the map (so the chain knows whether to look)."""

    UNCHANGED = "unchanged"
    """The body left the map as it was (the usual early return): no diff is computed."""
    CHANGED = "changed"
    """The body may have changed the map: it is compared before and after, changes reported."""


class Rule:
    """Base of every rule: subclasses set ``rulecode``, ``condition_text`` and ``act``.

    A rule compiles its conditions with the function registry of its session's
    :class:`RuleRegistry` (built-ins plus the extensions' functions).
    """

    rulecode: ClassVar[int]
    condition_text: ClassVar[str] = "! {TRUE}"
    description: ClassVar[str] = ""
    housekeeping: ClassVar[bool] = False
    """A rule that keeps the robot's mind running (kick-starting, blind stops, notes) rather
    than one a therapist reads: reports fold its firings away by default."""

    def __init__(self, message: RuleMessage, *, functions: FunctionRegistry) -> None:
        self.name = message.id
        self.intopic = message.intopic
        self.outtopic = message.outtopic
        self.functions = functions
        self.condition: Condition = compile_condition(self.condition_text, registry=functions)

    def set_condition(self, text: str) -> None:
        """Change the condition at run time (the thesis lets a rule do this itself)."""
        self.condition = compile_condition(text, registry=self.functions)

    def act(self, world_map: WorldMap, found: Evaluation, ctx: RuleContext) -> Effect:
        """The body, run when the condition holds; it may change the map freely.

        Return :attr:`Effect.UNCHANGED` when it left the map as it was (the chain then
        skips encoding the map), :attr:`Effect.CHANGED` when it may have changed it.
        """
        return Effect.UNCHANGED

    def tell(self, ctx: RuleContext, generator: str, text: str) -> None:
        """Send ``text`` to the selected generator ``generator`` (it hears it after this tick)."""
        ctx.notes.append(GeneratorNote(generator=generator, rule=self.name, text=text))

    def quiesce(self, ctx: RuleContext, generator: str) -> None:
        """Set the generator ``generator`` back to quiescence (the button shows Get Ready)."""
        ctx.notes.append(GeneratorNote(generator=generator, rule=self.name, quiesce=True))

    def decide(self, world_map: WorldMap, ctx: RuleContext) -> RuleDecision:
        """Evaluate the condition, run the body if it holds, and report what changed."""
        bound = (dict(world_map.aliases), dict(world_map.variables))
        found = self.condition.evaluate(world_map, now_ms=ctx.now_ms, tick_scope=ctx.tick_scope)
        if (world_map.aliases, world_map.variables) != bound:
            ctx.snapshot = None  # the condition bound U-scope aliases: not the body's doing
        changes: tuple[MapChange, ...] = ()
        if found.result:
            before = ctx.snapshot = ctx.snapshot or msgspec.json.encode(world_map)
            if self.act(world_map, found, ctx) is not Effect.UNCHANGED:
                after = ctx.snapshot = msgspec.json.encode(world_map)
                if after != before:
                    changes = tuple(diff(msgspec.json.decode(before), msgspec.json.decode(after)))
        return RuleDecision(
            rule=self.name,
            rulecode=self.rulecode,
            fired=found.result,
            bindings=dict(found.bindings),
            changes=changes,
        )


class RuleRegistry:
    """A session's rule classes by rule code, and the functions their conditions may call.

    Built by the composition root (built-ins plus extensions) and handed to the rule
    chain; immutable once built. Codes are unique; every condition text is compiled here.
    """

    def __init__(self, classes: Iterable[type[Rule]], *, functions: FunctionRegistry) -> None:
        self.functions = functions
        found: dict[int, type[Rule]] = {}
        for cls in classes:
            if cls.rulecode in found:
                taken = found[cls.rulecode].__name__
                raise ValueError(f"rule code {cls.rulecode} of {cls.__name__} is taken by {taken}")
            try:
                compile_condition(cls.condition_text, registry=functions)
            except RuleSyntaxError as error:
                raise ValueError(f"{cls.__name__}.condition_text: {error}") from error
            found[cls.rulecode] = cls
        self._classes = dict(sorted(found.items()))

    def create(self, message: RuleMessage) -> Rule:
        """A new rule instance for an alfa/omega message; unknown codes raise ``KeyError``."""
        return self._classes[message.rulecode](message, functions=self.functions)

    def __contains__(self, rulecode: object) -> bool:
        return rulecode in self._classes

    def codes(self) -> Mapping[int, type[Rule]]:
        """The rule classes by code, sorted."""
        return dict(self._classes)

    @property
    def version(self) -> str:
        """Hash of the codes, class names and condition texts, for recordings."""
        text = ";".join(
            f"{code}:{cls.__name__}:{cls.condition_text}" for code, cls in self._classes.items()
        )
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def diff(old: Any, new: Any, path: str = "") -> Iterator[MapChange]:
    """The leaves that differ between two builtin trees, as compact ``MapChange``s (a list
    whose length changed is one change; a missing key reads as ``null``)."""
    for where, a, b in differences(old, new, path, whole_lists=True):
        a, b = (None if a is ABSENT else a), (None if b is ABSENT else b)
        if a != b:
            yield MapChange(path=where, old=_text(a), new=_text(b))


def _text(value: Any) -> str:
    text = msgspec.json.encode(value).decode()
    return text if len(text) <= MAX_CHANGE_TEXT else text[: MAX_CHANGE_TEXT - 1] + "…"


RuleFactory = Callable[[RuleMessage], Rule]
