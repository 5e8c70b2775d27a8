"""Rules: a condition in the rule language and a body that may change the map (section 4.3).

A rule class is listed in a session's :class:`RuleRegistry` under its ``rulecode``;
alfa/omega messages name the code, and the chain instantiates the class with the
message's id and topics.
"""

from __future__ import annotations

import enum
import hashlib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import ClassVar, Final

from oimi.pipeline.events import MapChange, RuleDecision
from oimi.pipeline.messages import GeneratorNote, RuleMessage, WorldMap
from oimi.pipeline.think.condition_runtime import STORE_READS
from oimi.pipeline.think.conditions import Condition, Evaluation, compile_condition
from oimi.pipeline.think.errors import RuleSyntaxError
from oimi.pipeline.think.functions import TIME, FunctionRegistry
from oimi.pipeline.think.mapparts import (
    FIELDS,
    MAX_CHANGE_TEXT,
    MapParts,
    Stores,
    diff,
    map_changes,
    stores_of,
)

__all__ = ["MAX_CHANGE_TEXT", "Effect", "Rule", "RuleContext", "RuleRegistry", "diff"]


@dataclass
class RuleContext:
    """What a rule body may read besides the map: the clock and the scripts it can switch to."""

    now_ms: int
    tick_scope: dict[str, str] = field(default_factory=dict)
    parts: MapParts | None = None
    """The map's parts encoded during this pass (made by the first rule): what skipped rules
    compare, and the map as the last fired rule left it (its baseline is reset when a
    condition binds scope-U aliases or variables, so a body's diff is its own)."""
    notes: list[GeneratorNote] = field(default_factory=list)
    """Messages the rules wrote to script generators this tick (delivered by the loop)."""
    shortcuts: bool = True
    """Skip a rule whose condition would find what it read at its last evaluation that did
    not hold (see :class:`Memo`), compare only the parts of the map a body declares it
    writes (:attr:`Rule.writes`), and encode them only when a body that announces its
    changes (:attr:`Rule.announces`) makes one. Off: every rule is evaluated, the whole
    map compared (encoded before each body)."""
    writing: tuple[str, ...] = ()
    """The parts of the map the running body may change."""
    before: dict[str, bytes] | None = None
    """Those parts, encoded before the body changed them (``None`` until :meth:`changing`)."""
    stores: Stores | None = None
    """What the alias and variable stores and the tick scope hold (:func:`stores_of`), kept
    from the last evaluation or skip while no body has run since (``None``: taken anew):
    the next rule's condition finds them as that one left them."""

    def changing(self) -> None:
        """What a body calls before it first changes the map: the parts it may change are
        encoded as they are (for a rule that :attr:`Rule.announces` its changes, only
        then; for any other, before its body ran)."""
        if self.before is None and self.parts is not None:
            self.parts.settle()
            self.before = self.parts.before(self.writing)


class Effect(enum.Enum):
    """What a rule body says it did to the map (so the chain knows whether to look)."""

    UNCHANGED = "unchanged"
    """The body left the map as it was (the usual early return): no diff is computed."""
    CHANGED = "changed"
    """The body may have changed the map: it is compared before and after, changes reported."""


_UNCHANGED: Final = Effect.UNCHANGED
"""Read at every rule that fires: a global, not the enum class's slow attribute path."""


class Rule:
    """Base of every rule: subclasses set ``rulecode``, ``condition_text`` and ``act``.

    A rule compiles its conditions with the function registry of its session's
    :class:`RuleRegistry` (built-ins plus the extensions' functions).
    """

    rulecode: ClassVar[int]
    _memo: Memo | None = None
    condition_text: ClassVar[str] = "! {TRUE}"
    description: ClassVar[str] = ""
    writes: ClassVar[tuple[str, ...] | None] = None
    """The parts of the map (``WorldMap`` fields) the body may change; only these are
    compared after it. ``None``: any part."""
    announces: ClassVar[bool] = False
    """Whether the body calls ``ctx.changing()`` (:meth:`RuleContext.changing`) before it
    first changes the map, and changes nothing when it returns early without calling it:
    the parts it writes are then encoded only when it changes them, not at every firing."""
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
        self._memo = None  # (a condition compiled before is shared: remember nothing of it)

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
        """Evaluate the condition, run the body if it holds, and report what changed.

        A condition that declares what it reads (:attr:`Condition.reads`) and finds it as
        at its last evaluation that did not hold is not run again (see :class:`Memo`)."""
        condition = self.condition
        memo = self._memo
        if memo is None or memo.condition is not condition:
            memo = self._memo = Memo(condition)
        parts = ctx.parts
        if parts is None or parts.world_map is not world_map:
            parts = ctx.parts = MapParts(world_map)
        stores = None
        if memo.stores:
            stores = ctx.stores
            if stores is None:
                stores = ctx.stores = stores_of(world_map, ctx.tick_scope)
        inputs = None
        later = False
        if memo.paths is not None and ctx.shortcuts:
            if memo.wait:
                memo.wait -= 1
            elif memo.last is None:  # nothing to compare with: encoded if it does not hold
                later = True  # (the evaluation changes none of the parts it reads)
            else:
                inputs = memo.inputs(stores, parts)
                last = memo.last
                if memo.compared(inputs, last[0] == inputs):
                    if last[2] is not None:  # it bound or released aliases or variables
                        _restore((world_map.aliases, world_map.variables, ctx.tick_scope), last[2])
                        ctx.stores = last[2]
                        parts.rebound()
                    return last[1]
        if not memo.known:  # its functions may change anything: the parts a fired body
            parts.settle()  # left to the map are encoded first, and all are stale after
        found = condition.evaluate(world_map, now_ms=ctx.now_ms, tick_scope=ctx.tick_scope)
        if not memo.known:
            parts.forget()
        after = stores  # (an evaluation binding nothing in scope U or T leaves them)
        if memo.binds:
            after = ctx.stores = stores_of(world_map, ctx.tick_scope)
        moved = after != stores
        if moved:
            parts.rebound()  # the condition bound U-scope aliases: not the body's doing
        changes: tuple[MapChange, ...] = ()
        if found.result:
            ctx.writing = self.writes if ctx.shortcuts and self.writes is not None else FIELDS
            ctx.before = None
            ctx.stores = None  # the body may change them
            if self.announces and ctx.shortcuts:
                parts.defer(ctx.writing)
            else:
                ctx.changing()
            effect = self.act(world_map, found, ctx)
            if effect is not _UNCHANGED:  # (a body that left the map as it was leaves
                parts.forget()  # its parts' encodings good for the rules after it)
                before = ctx.before
                if before is None:
                    name = type(self).__name__
                    raise RuntimeError(f"{name}.act changed the map without ctx.changing()")
                changes = map_changes(before, parts.after(ctx.writing, before))
        decision = RuleDecision(
            rule=self.name,
            rulecode=self.rulecode,
            fired=found.result,
            bindings=dict(found.bindings),
            changes=changes,
        )
        if later and not found.result:
            inputs = memo.inputs(stores, parts)
        if inputs is not None and not found.result:
            memo.last = (inputs, decision, after if moved else None)
        return decision


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
            check_rule(cls, functions=functions)
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


def check_writes(cls: type[Rule]) -> None:
    """``ValueError`` unless ``cls.writes`` is ``None`` or a tuple of the map's parts."""
    writes = cls.writes
    if writes is None:
        return
    if not isinstance(writes, tuple | list) or not all(isinstance(p, str) for p in writes):
        shown = f"the str {writes!r}" if isinstance(writes, str) else repr(writes)
        example = writes if isinstance(writes, str) else "scriptinfo"
        raise ValueError(
            f'{cls.__name__}.writes must be a tuple of map parts, e.g. ("{example}",), not {shown}'
        )
    unknown = [part for part in writes if part not in FIELDS]
    if unknown:
        raise ValueError(f"{cls.__name__}.writes: {unknown} are not parts of the map")


def check_rule(cls: type[Rule], *, functions: FunctionRegistry) -> None:
    """``ValueError`` for a rule class its session would refuse: bad ``writes``, or a
    ``condition_text`` that does not compile with ``functions``."""
    check_writes(cls)
    try:
        compile_condition(cls.condition_text, registry=functions)
    except RuleSyntaxError as error:
        raise ValueError(f"{cls.__name__}.condition_text: {error}") from error


MAX_WAIT: Final = 8
"""The evaluations a rule goes without comparing its inputs when comparing does not pay."""
EVALUATION_BYTES: Final = 4000
"""About what evaluating a condition costs, in bytes of the map encoded to compare its
inputs (the library's conditions take 1 to 5 us; encoding takes about 1 us per kB)."""


class Memo:
    """What a rule remembers of its condition to skip evaluations that would repeat one.

    An evaluation reads only :attr:`Condition.reads` (map parts, the stores) and writes
    only the stores, so one that finds all of them as the last evaluation that did not
    hold found them would decide the same and write the same. Comparing costs encoding
    the parts read, so a rule compares only while it pays: while the share of its
    comparisons that found the inputs unchanged, times an evaluation
    (:data:`EVALUATION_BYTES`), outweighs their size; else once in ``MAX_WAIT + 1``
    evaluations. With no evaluation to compare with, it encodes them after evaluating
    (which changes none of them), only when the condition did not hold. A condition that
    may read anything (a function without ``reads``) or reads the clock (new at every
    tick) is always evaluated.
    """

    __slots__ = ("binds", "condition", "known", "last", "paths", "rate", "stores", "wait")

    def __init__(self, condition: Condition) -> None:
        self.condition = condition
        reads = getattr(condition, "reads", None)
        self.known = reads is not None
        """Whether the condition's reads are declared (else it may change the map)."""
        self.stores = reads is None or any(path in STORE_READS for path in reads)
        """Whether an evaluation may read and write the alias and variable stores."""
        self.binds = self.stores and condition.binds
        """Whether an evaluation may write them (:attr:`Condition.binds`)."""
        self.paths = (
            None
            if reads is None or TIME in reads
            else tuple(path for path in reads if path not in STORE_READS)
        )
        """The map parts compared (``None``: never skipped)."""
        self.last: tuple[tuple[object, ...], RuleDecision, Stores | None] | None = None
        """The last evaluation that did not hold and was compared: what it found, its
        decision and, when it wrote to the stores, what they held after it."""
        self.rate = 1.0
        """The running share of comparisons that found the inputs unchanged."""
        self.wait = 0

    def inputs(self, stores: Stores | None, parts: MapParts) -> tuple[object, ...]:
        """What an evaluation reads: the stores' contents and the parts, encoded."""
        return (stores, *[parts.encoded(path) for path in self.paths or ()])

    def compared(self, inputs: tuple[object, ...], unchanged: bool) -> bool:
        """Note what comparing ``inputs`` found (and whether the next evaluation compares
        again); return ``unchanged``."""
        self.rate += (unchanged - self.rate) / 8
        size = sum(map(len, inputs[1:]))  # type: ignore[arg-type]
        self.wait = 0 if self.rate * EVALUATION_BYTES >= size else MAX_WAIT
        return unchanged


def _restore(stores: tuple[dict[str, str], ...], contents: Stores) -> None:
    """Make each store hold its items again, in the same order."""
    for store, items in zip(stores, contents, strict=True):
        store.clear()
        store.update(items)


RuleFactory = Callable[[RuleMessage], Rule]
