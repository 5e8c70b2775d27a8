"""The function registry of the rule language: families B, F and E, filled by decorators.

A function is plain Python marked with one of the decorators below; a
:class:`FunctionRegistry` collects marked functions (no process-wide state)::

    @boolean("infront")
    def infront(ctx: FunctionContext, entity: Bound, max_angle_rad: float = 0.5) -> bool: ...

Arity and argument kinds come from the signature: a parameter annotated with an
entity type takes an alias (``?child``), ``float``/``int`` a number (strings are
cast when the condition runs; a failed cast makes the call false), ``str`` a
text; defaults and ``*args`` are supported.

A function may declare what it reads besides its arguments (``reads=("cameras",)``,
``reads=(TIME,)``): map fields by path and the clock. A rule whose condition calls
only declaring functions is skipped while nothing it reads changed; a function that
declares nothing is taken to read everything, and its rules are always evaluated.
"""

from __future__ import annotations

import enum
import hashlib
import inspect
import types
import typing
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Final

import msgspec
from oimi.pipeline.errors import named
from oimi.pipeline.messages import ACTIVITY_CLASS, ENTITY_LISTS, ActivityTracking, Entity, WorldMap

if TYPE_CHECKING:
    from oimi.pipeline.think.condition_runtime import Condition

Bound = Entity | ActivityTracking
"""What an alias can be bound to: a human, obstacle, object or activity of the map."""

CLASS_NAMES: Final = (*(m.name for m in ENTITY_LISTS), ACTIVITY_CLASS)
"""The classes a ``CLASS`` clause can look for (``#Human``...)."""

SPEC_ATTRIBUTE: Final = "__oimi_rule_function__"

TIME: Final = "now_ms"
"""In a function's ``reads``: it reads the clock (``ctx.now_ms``)."""


class Family(enum.StrEnum):
    """The three families of the rule language (the letter before ``:``)."""

    B = "B"
    """Boolean on an entity: criteria of a ``CLASS`` clause, ``fn(ctx, entity, *args) -> bool``."""
    F = "F"
    """String: values of ``VAR`` and ``ATT`` clauses, ``fn(ctx, *args) -> str | None``."""
    E = "E"
    """Evaluation: the right of ``!``, ``fn(ctx, *args) -> bool``."""


class ArgKind(enum.Enum):
    """What a parameter accepts, read from its annotation."""

    ENTITY = "an alias (?name)"
    OPTIONAL_ENTITY = "an alias (?name), possibly unbound"
    NUMBER = "a number"
    TEXT = "a text"
    ANY = "any value"


class FunctionContext(msgspec.Struct, frozen=True):
    """What every rule function sees besides its arguments (a Struct: built in C, once for
    each evaluation that calls a function; a frozen dataclass's ``__init__`` ran as Python)."""

    world_map: WorldMap
    now_ms: int
    """The simulated time of the evaluation, ms."""


@dataclass(frozen=True, slots=True)
class FunctionSpec:
    """One registered function: its family, arity and the kinds of its arguments."""

    name: str
    family: Family
    fn: Callable[..., object]
    kinds: tuple[ArgKind, ...]
    """Kinds of the positional parameters the condition gives (ctx and B's entity excluded)."""
    min_args: int
    max_args: int | None
    """``None`` when the function takes ``*args``."""
    vararg_kind: ArgKind | None
    entity_types: tuple[tuple[type, ...], ...]
    """For each parameter (then ``*args``): the entity types it accepts (empty: not an entity)."""
    classes: tuple[str, ...]
    """For family B: the classes whose entities it applies to."""
    signature: str
    """``name (a, b=1, *rest)`` as shown in errors and the documentation."""
    reads: tuple[str, ...] | None = None
    """What it reads besides its arguments (and, for B, its entity): map field paths
    (``"robotstatus.touch"``) and :data:`TIME`; ``None``: anything (never skipped)."""

    @property
    def doc(self) -> str:
        return inspect.getdoc(self.fn) or ""

    def kind(self, index: int) -> ArgKind:
        """Kind of the argument at ``index`` (0-based, as written in the condition)."""
        if index < len(self.kinds):
            return self.kinds[index]
        return self.vararg_kind or ArgKind.ANY

    def accepts(self, index: int) -> tuple[type, ...]:
        """Entity types the argument at ``index`` accepts (empty when it is not an entity)."""
        if index < len(self.kinds):
            return self.entity_types[index]
        return self.entity_types[-1] if self.vararg_kind is not None else ()

    def arity_text(self) -> str:
        if self.max_args is None:
            return f"at least {self.min_args}"
        if self.min_args == self.max_args:
            return str(self.min_args)
        return f"{self.min_args} to {self.max_args}"


def check_read(path: str) -> str:
    """``path`` if it names :data:`TIME` or a field of the map (``"humans"``,
    ``"robotstatus.touch"``), else ``ValueError``."""
    if path == TIME:
        return path
    struct: object = WorldMap
    for part in path.split("."):
        fields = getattr(struct, "__struct_fields__", ())
        if part not in fields:
            raise ValueError(f"{path!r} is not {TIME!r} nor a field path of the map")
        struct = typing.get_type_hints(struct).get(part)
    return path


def _mark(
    family: Family, name: str, classes: tuple[str, ...], reads: Iterable[str] | None
) -> Callable:
    declared = None if reads is None else tuple(check_read(path) for path in reads)

    def decorate(fn: Callable) -> Callable:
        setattr(fn, SPEC_ATTRIBUTE, (family, name, classes, declared))
        return fn

    return decorate


def boolean(
    name: str, *, classes: Iterable[str] = CLASS_NAMES, reads: Iterable[str] | None = None
) -> Callable:
    """Mark a B function ``fn(ctx, entity, *args) -> bool``, usable on entities of ``classes``;
    ``reads``: what it reads besides its arguments and entity (``None``: anything)."""
    classes = tuple(classes)
    unknown = [c for c in classes if c not in CLASS_NAMES]
    if unknown:
        raise ValueError(f"unknown classes {unknown} for B function {name!r}")
    return _mark(Family.B, name, classes, reads)


def string(name: str, *, reads: Iterable[str] | None = None) -> Callable:
    """Mark an F function ``fn(ctx, *args) -> str | None`` (``None``: the assignment fails);
    ``reads``: what it reads besides its arguments (``None``: anything)."""
    return _mark(Family.F, name, (), reads)


def evaluation(name: str, *, reads: Iterable[str] | None = None) -> Callable:
    """Mark an E function ``fn(ctx, *args) -> bool``; ``reads``: what it reads besides its
    arguments (``None``: anything)."""
    return _mark(Family.E, name, (), reads)


def _is_bound_type(tp: object) -> bool:
    return isinstance(tp, type) and issubclass(tp, (Entity, ActivityTracking))


def _kind_of(annotation: object) -> tuple[ArgKind, tuple[type, ...]]:
    if annotation in (float, int):
        return ArgKind.NUMBER, ()
    if annotation is str:
        return ArgKind.TEXT, ()
    if _is_bound_type(annotation):
        return ArgKind.ENTITY, (annotation,)  # type: ignore[return-value]
    if isinstance(annotation, types.UnionType) or typing.get_origin(annotation) is typing.Union:
        members = typing.get_args(annotation)
        non_none = tuple(m for m in members if m is not type(None))
        if non_none and all(_is_bound_type(m) for m in non_none):
            optional = len(non_none) < len(members)
            return (ArgKind.OPTIONAL_ENTITY if optional else ArgKind.ENTITY), non_none
        if non_none and all(m in (float, int) for m in non_none):
            return ArgKind.NUMBER, ()
    return ArgKind.ANY, ()


def spec_of(fn: Callable) -> FunctionSpec:
    """Read the spec of a marked function (raises ``ValueError`` on an unmarked one)."""
    mark = getattr(fn, SPEC_ATTRIBUTE, None)
    if mark is None:
        raise ValueError(f"{named(fn)} is not marked with @boolean, @string or @evaluation")
    family, name, classes, reads = mark
    hints = typing.get_type_hints(fn)
    params = list(inspect.signature(fn).parameters.values())
    skip = 2 if family is Family.B else 1  # ctx (and the entity for B)
    if len(params) < skip:
        raise ValueError(f"rule function {name!r} must take ctx{', entity' if skip == 2 else ''}")
    kinds: list[ArgKind] = []
    entity_types: list[tuple[type, ...]] = []
    vararg_kind = None
    min_args = 0
    max_args: int | None = 0
    shown: list[str] = []
    for param in params[skip:]:
        kind, accepted = _kind_of(hints.get(param.name, object))
        if param.kind is param.VAR_POSITIONAL:
            vararg_kind = kind
            entity_types.append(accepted)
            max_args = None
            shown.append(f"*{param.name}")
        elif param.kind in (param.POSITIONAL_ONLY, param.POSITIONAL_OR_KEYWORD):
            kinds.append(kind)
            entity_types.append(accepted)
            assert max_args is not None
            max_args += 1
            if param.default is param.empty:
                min_args += 1
                shown.append(param.name)
            else:
                shown.append(f"{param.name}={param.default!r}")
        elif param.default is param.empty:
            raise ValueError(f"rule function {name!r}: keyword-only {param.name!r} needs a default")
    return FunctionSpec(
        name=name,
        family=family,
        fn=fn,
        kinds=tuple(kinds),
        min_args=min_args,
        max_args=max_args,
        vararg_kind=vararg_kind,
        entity_types=tuple(entity_types),
        classes=classes,
        signature=f"{name} ({', '.join(shown)})",
        reads=reads,
    )


class FunctionRegistry:
    """The functions a condition may call, by name (names are unique across families)."""

    def __init__(self, functions: Iterable[Callable] = ()):
        specs: dict[str, FunctionSpec] = {}
        for fn in functions:
            spec = spec_of(fn)
            if spec.name in specs:
                raise ValueError(f"rule function {spec.name!r} registered twice")
            specs[spec.name] = spec
        self._specs = dict(sorted(specs.items()))
        lines = "\n".join(f"{s.family}:{s.signature}" for s in self._specs.values())
        self.version: str = hashlib.sha256(lines.encode()).hexdigest()[:16]
        """Hash of the sorted names and signatures, for recordings."""
        self.conditions: dict[str, Condition] = {}
        """The conditions compiled with these functions, by text (``compile_condition``'s)."""

    @classmethod
    def from_module(cls, module: types.ModuleType) -> FunctionRegistry:
        """Every marked function defined in ``module``."""
        marked = [
            value
            for value in vars(module).values()
            if callable(value) and hasattr(value, SPEC_ATTRIBUTE)
        ]
        return cls(marked)

    def functions(self) -> list[Callable[..., object]]:
        """The registered functions, sorted by name (to build a larger registry)."""
        return [spec.fn for spec in self._specs.values()]

    def get(self, name: str) -> FunctionSpec | None:
        return self._specs.get(name)

    def names(self, family: Family | None = None) -> list[str]:
        """Sorted names, optionally of one family."""
        return [n for n, s in self._specs.items() if family is None or s.family is family]

    def __iter__(self) -> Iterator[FunctionSpec]:
        return iter(self._specs.values())

    def __len__(self) -> int:
        return len(self._specs)

    def __contains__(self, name: object) -> bool:
        return name in self._specs
