"""Running a compiled condition: the state of one evaluation, value casts and the results.

Keys used in the stores (the map's ``aliases``/``variables``, the per-tick dict
and :attr:`Evaluation.bindings`) carry their sigil: ``"?child"`` (an alias, value
``"Human/c1"``), ``"@mood"`` (a variable), ``"?child$mood"`` (an attribute bound
to the alias ``?child``).
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Sequence
from typing import Final

import msgspec
from oimi.pipeline.messages import ACTIVITY_CLASS, ENTITY_LISTS, ActivityTracking, WorldMap
from oimi.pipeline.think.condition_ast import (
    Op,
    Scope,
)
from oimi.pipeline.think.functions import (
    Bound,
    FunctionContext,
)

# ----------------------------------------------------------------- evaluation state

MISSING: Final = object()
"""A value that could not be found or cast: the criterion, call or assignment fails."""


def entity_ref(cls: str, entity: Bound) -> str:
    """``"Human/c1"``: how an alias names its entity (activities by ``activityname``)."""
    # The exact class (nothing derives from it): ``isinstance`` on a Struct class that
    # misses goes through msgspec's metaclass, and most entities are not activities.
    key = entity.activityname if type(entity) is ActivityTracking else entity.id
    return f"{cls}/{key}"


_ENTITY_FIELDS: Final = {m.name: m.field for m in ENTITY_LISTS}

ENTITY_READS: Final = {**_ENTITY_FIELDS, ACTIVITY_CLASS: "robotstatus.activities"}
"""Where a condition reads the entities of each class (a :attr:`Condition.reads` path)."""

TICK_SCOPE: Final = "tick_scope"
"""In :attr:`Condition.reads`: the rule chain's per-tick store (scope T)."""

STORE_READS: Final = ("aliases", "variables", TICK_SCOPE)
"""What looking up an alias or a variable reads: the map's scope-U stores and scope T."""

_U: Final = Scope.U
_T: Final = Scope.T
"""Read at every evaluation: a global, not the enum class's slow attribute path."""


def entities_of(world_map: WorldMap, cls: str) -> Sequence[Bound]:
    field = _ENTITY_FIELDS.get(cls)
    if field is not None:
        return getattr(world_map, field)
    if cls == ACTIVITY_CLASS:
        return world_map.robotstatus.activities
    return ()


def find_entity(world_map: WorldMap, ref: str) -> Bound | None:
    """The entity named by ``ref`` (``"Human/c1"``), or ``None`` when it is not in the map."""
    cls = ref.partition("/")[0]
    for entity in entities_of(world_map, cls):
        if entity_ref(cls, entity) == ref:
            return entity
    return None


def is_alias_key(key: str) -> bool:
    return key.startswith("?") and "$" not in key


def release_alias(
    world_map: WorldMap, alias: str, tick_scope: dict[str, str] | None = None
) -> None:
    """Remove ``alias`` and the attributes bound to it from the map (scope U) and ``tick_scope``."""
    for store in (world_map.aliases, world_map.variables, tick_scope or {}):
        for key in [k for k in store if k == alias or k.startswith(alias + "$")]:
            del store[key]


class Run:
    """The state of one evaluation."""

    __slots__ = ("_ctx", "bindings", "local", "now_ms", "tick", "world_map")

    def __init__(self, world_map: WorldMap, now_ms: int, tick: dict[str, str]):
        self.world_map = world_map
        self.now_ms = now_ms
        self._ctx: FunctionContext | None = None
        self.tick = tick
        self.local: dict[str, str] = {}
        self.bindings: dict[str, str] = {}

    @property
    def ctx(self) -> FunctionContext:
        """What rule functions see; made on the first call (many conditions call none)."""
        if self._ctx is None:
            self._ctx = FunctionContext(world_map=self.world_map, now_ms=self.now_ms)
        return self._ctx

    def store(self, scope: Scope) -> dict[str, str]:
        if scope is _U:
            return self.world_map.variables
        return self.tick if scope is _T else self.local

    def alias_store(self, scope: Scope) -> dict[str, str]:
        return self.world_map.aliases if scope is _U else self.store(scope)

    def lookup(self, key: str, stores: tuple[dict[str, str], ...]) -> str | None:
        for store in stores:
            value = store.get(key)
            if value is not None:
                return value
        return None

    def alias_ref(self, alias: str) -> str | None:
        """The entity ``alias`` names: as this evaluation bound it, else as scope L, T, U do."""
        return self.lookup(alias, (self.bindings, self.local, self.tick, self.world_map.aliases))

    def entity(self, alias: str) -> Bound | None:
        ref = self.alias_ref(alias)
        return None if ref is None else find_entity(self.world_map, ref)

    def variable(self, name: str) -> str | None:
        return self.lookup(name, (self.local, self.tick, self.world_map.variables))

    def attribute(self, alias: str, att: str) -> object:
        value = self.lookup(f"{alias}${att}", (self.local, self.tick, self.world_map.variables))
        if value is not None:
            return value
        entity = self.entity(alias)
        attributes = getattr(entity, "attributes", None)
        if attributes is None or att not in attributes:
            return MISSING
        return attributes[att]

    def unbind_alias(self, alias: str, scope: Scope) -> None:
        """Release ``alias`` and the attributes bound to it in ``scope`` (the thesis's scopes
        are separate: a rule's L alias never releases another rule's U alias of that name)."""
        for store in (self.alias_store(scope), self.store(scope)):
            for key in [k for k in store if k == alias or k.startswith(alias + "$")]:
                del store[key]

    def taken(self, alias: str) -> set[str]:
        """Entities already bound to another live alias."""
        return {
            ref
            for store in (self.local, self.tick, self.world_map.aliases)
            for key, ref in store.items()
            if key != alias and is_alias_key(key)
        }


# ---------------------------------------------------------------------- casting


def to_number(value: object) -> object:
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, int | float):
        return value
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return MISSING
    return MISSING


_TRUE_TEXTS: Final = {
    "true": True,
    "1": True,
    "s_true": True,  # the thesis's booleans (tables 4.1 and 4.2)
    "false": False,
    "0": False,
    "s_false": False,
}


def to_bool(value: object) -> object:
    if isinstance(value, bool):
        return value
    if isinstance(value, int | float):
        return value != 0
    if isinstance(value, str):
        return _TRUE_TEXTS.get(value.strip().lower(), MISSING)
    return MISSING


def to_text(value: object) -> object:
    if isinstance(value, str):
        return value
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return str(int(value)) if value.is_integer() else repr(value)
    return MISSING


def compare(left: object, op: Op, right: object) -> bool:
    """Compare a field with a value cast to the field's type (numbers compare numerically)."""
    if right is MISSING or left is MISSING:
        return False
    if isinstance(left, bool):
        right = to_bool(right)
    elif isinstance(left, int | float):
        right = to_number(right)
    elif isinstance(right, int | float) and not isinstance(right, bool):
        left = to_number(left)
    else:
        right = to_text(right)
    if left is MISSING or right is MISSING:
        return False
    try:
        if op is Op.EQ:
            return left == right
        if op is Op.LT:
            return left < right  # type: ignore[operator]
        return left > right  # type: ignore[operator]
    except TypeError:
        return False


NUMBER_OPS: Final[dict[Op, Callable[[float, float], bool]]] = {
    Op.EQ: operator.eq,
    Op.LT: operator.lt,
    Op.GT: operator.gt,
}
"""What ``compare`` does for two numbers."""

Getter = Callable[[Run, Bound | None], object]
GO, FAIL, TRUE = 0, 1, 2
Step = Callable[[Run], int]

# ------------------------------------------------------------------- public API


class Evaluation(msgspec.Struct, frozen=True, kw_only=True):
    """The outcome of evaluating a condition once."""

    result: bool
    bindings: dict[str, str] = {}
    """Every alias, variable and attribute bound during the evaluation, in binding order:
    ``"?child" -> "Human/c1"``, ``"@mood" -> "happy"``, ``"?child$mood" -> "calm"``."""

    def entity(self, world_map: WorldMap, alias: str) -> Bound | None:
        """The map entity bound to ``alias`` by this evaluation, or ``None``."""
        ref = self.bindings.get(alias)
        return None if ref is None or not is_alias_key(alias) else find_entity(world_map, ref)


class Condition:
    """A compiled condition: closures only, no parsing at evaluation time."""

    __slots__ = ("_steps", "aliases", "binds", "reads", "registry_version", "text")

    def __init__(
        self,
        text: str,
        steps: tuple[Step, ...],
        aliases: tuple[str, ...],
        version: str,
        *,
        reads: tuple[str, ...] | None = None,
        binds: bool = True,
    ):
        self.text = text
        self._steps = steps
        self.aliases = aliases
        """Aliases the condition's CLASS clauses bind, in order."""
        self.registry_version = version
        self.reads = reads
        """Everything an evaluation reads, sorted: map field paths (``"humans"``,
        ``"robotstatus.touch"``), ``"now_ms"`` (the clock) and ``"tick_scope"``; ``None``
        when it calls a function that may read anything. Two evaluations that find all of
        these equal give the same result."""
        self.binds = binds or reads is None
        """Whether an evaluation may write the map's alias and variable stores or the tick
        scope (a CLASS, VAR or ATT clause of scope U or T, or a function that may do
        anything); scope L binds nothing there."""

    def evaluate(
        self, world_map: WorldMap, *, now_ms: int, tick_scope: dict[str, str] | None = None
    ) -> Evaluation:
        """Run the clauses left to right on ``world_map`` (writes scopes U and T, see module doc).

        Without ``tick_scope``, T-scope bindings last only for this evaluation.
        """
        run = Run(world_map, now_ms, {} if tick_scope is None else tick_scope)
        result = True
        for step in self._steps:
            outcome = step(run)
            if outcome == FAIL:
                result = False
                break
            if outcome == TRUE:
                break
        return Evaluation(result=result, bindings=run.bindings)  # the run ends here: no copy

    def __repr__(self) -> str:
        return f"Condition({self.text!r})"
