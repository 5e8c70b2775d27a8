"""The Script Generator protocol (thesis 3.2), its option specs and the catalogue.

A generator starts quiescent; ``activate(options)`` validates its options and
readies it, ``generate()`` returns a :class:`~pipeline.messages.Script`,
``shutdown()`` returns it to quiescence. Generators are pure: no files, no
clock; the same options, map view and state give the same script.

As in the thesis (3.2), a generator may also ``see`` a read-only view of the map
just before it generates, keep its own state between scripts (the instance lives
as long as the operator's selection), and ``hear`` the messages rules address to
it (:class:`~pipeline.messages.GeneratorNote`); a rule may set it quiescent.
"""

from __future__ import annotations

import enum
import math
import re
from collections.abc import Callable, Mapping
from typing import Final, Protocol, TypeVar

import msgspec
from oimi.pipeline.errors import FAILURES, LocatedError, failure
from oimi.pipeline.messages import GeneratorNote, Message, Script, WorldMap

Colour = tuple[float, float, float]
_T = TypeVar("_T")
OptionValue = str | float | int | Colour | tuple[Colour, ...]


class GeneratorError(LocatedError):
    """A generator refused its options or could not generate; ``option`` names the culprit."""

    def __init__(
        self,
        message: str,
        *,
        source: str = "<generator>",
        line: int = 0,
        column: int = 0,
        option: str = "",
    ):
        super().__init__(message, source=source, line=line, column=column)
        self.option = option


class OptionKind(enum.StrEnum):
    """How an option's text is read (and which widget a UI shows for it)."""

    CHOICE = "choice"
    """One of ``choices``; when ``min``/``max`` are given, a number in that range too."""
    NUMBER = "number"
    """A decimal number in [``min``, ``max``] (an integer when ``integer``)."""
    COLOUR = "colour"
    """A colour name (see ``COLOURS``) or ``#rrggbb``."""
    TEXT = "text"
    """Free, non-empty text."""


COLOURS: Final[dict[str, Colour]] = {
    "red": (1.0, 0.0, 0.0),
    "green": (0.0, 1.0, 0.0),
    "blue": (0.0, 0.0, 1.0),
    "yellow": (1.0, 1.0, 0.0),
    "cyan": (0.0, 1.0, 1.0),
    "magenta": (1.0, 0.0, 1.0),
    "white": (1.0, 1.0, 1.0),
    "orange": (1.0, 0.5, 0.0),
    "purple": (0.5, 0.0, 1.0),
    "pink": (1.0, 0.4, 0.7),
}
"""Colour names accepted by ``colour`` options, as RGB in [0, 1]."""

_HEX: Final = re.compile(r"#([0-9a-fA-F]{2})([0-9a-fA-F]{2})([0-9a-fA-F]{2})")


class OptionSpec(Message):
    """One option of a generator, enough for a UI to render its screen (thesis Fig. 5.10)."""

    name: str
    kind: OptionKind
    default: str
    """The value (as text) used when the operator gives none."""
    help: str = ""
    choices: tuple[str, ...] = ()
    min: float | None = None
    max: float | None = None
    integer: bool = False
    """Numbers must be whole (``number`` kind, or the numeric side of ``choice``)."""
    multiple: bool = False
    """A comma-separated list of values (at least one)."""

    def parse(self, text: str, *, source: str = "<generator>") -> OptionValue:
        """The typed value of ``text``; a :class:`GeneratorError` naming the option if bad."""
        if self.multiple:
            parts = [p.strip() for p in text.split(",")]
            if not text.strip() or any(not p for p in parts):
                raise self._error(f"{text!r} is not a comma-separated list of values", source)
            return tuple(self._one(p, source) for p in parts)  # type: ignore[return-value]
        return self._one(text.strip(), source)

    def _one(self, text: str, source: str) -> OptionValue:
        match self.kind:
            case OptionKind.CHOICE:
                if text in self.choices:
                    return text
                if self.min is not None or self.max is not None:
                    try:
                        return self._number(text, source)
                    except GeneratorError:
                        pass
                raise self._error(f"{text!r} is not {self._expected()}", source)
            case OptionKind.NUMBER:
                return self._number(text, source)
            case OptionKind.COLOUR:
                if text.lower() in COLOURS:
                    return COLOURS[text.lower()]
                m = _HEX.fullmatch(text)
                if m:
                    return tuple(round(int(h, 16) / 255, 4) for h in m.groups())  # type: ignore[return-value]
                raise self._error(f"{text!r} is not {self._expected()}", source)
            case OptionKind.TEXT:
                if not text:
                    raise self._error("must not be empty", source)
                return text
        raise AssertionError(self.kind)  # pragma: no cover

    def _number(self, text: str, source: str) -> float | int:
        try:
            value = float(text)
        except ValueError:
            raise self._error(f"{text!r} is not {self._expected()}", source) from None
        if not math.isfinite(value):
            raise self._error(f"{text!r} is not a finite number", source)
        if self.integer and value != int(value):
            raise self._error(f"{text!r} is not a whole number", source)
        lo = -math.inf if self.min is None else self.min
        hi = math.inf if self.max is None else self.max
        if not lo <= value <= hi:
            raise self._error(f"{text} is out of range {self._range()}", source)
        return int(value) if self.integer else value

    def _range(self) -> str:
        def show(v: float | None) -> str:
            return "" if v is None else f"{v:g}"

        return f"{show(self.min)}..{show(self.max)}"

    def _expected(self) -> str:
        match self.kind:
            case OptionKind.CHOICE:
                text = "one of " + ", ".join(self.choices)
                if self.min is not None or self.max is not None:
                    text += f" or a number in {self._range()}"
                return text
            case OptionKind.NUMBER:
                return ("a whole number" if self.integer else "a number") + f" in {self._range()}"
            case OptionKind.COLOUR:
                return "a colour (" + ", ".join(COLOURS) + " or #rrggbb)"
        return "non-empty text"

    def _error(self, what: str, source: str) -> GeneratorError:
        return GeneratorError(f"option {self.name!r}: {what}", source=source, option=self.name)


def resolve_options(
    specs: tuple[OptionSpec, ...], options: Mapping[str, str], *, source: str = "<generator>"
) -> dict[str, str]:
    """The options as text, defaults filled in, in spec order; unknown or bad ones raise."""
    known = {s.name for s in specs}
    for name in sorted(options):
        if name not in known:
            listed = ", ".join(s.name for s in specs) or "none"
            raise GeneratorError(
                f"unknown option {name!r} (options: {listed})", source=source, option=name
            )
    resolved: dict[str, str] = {}
    for spec in specs:
        text = options.get(spec.name, spec.default)
        spec.parse(text, source=source)
        resolved[spec.name] = text
    return resolved


def parse_options(
    specs: tuple[OptionSpec, ...], options: Mapping[str, str], *, source: str = "<generator>"
) -> dict[str, OptionValue]:
    """The typed options, defaults filled in, in spec order; unknown or bad ones raise."""
    resolved = resolve_options(specs, options, source=source)
    return {s.name: s.parse(resolved[s.name], source=source) for s in specs}


class Generator(Protocol):
    """A Script Generator: quiescent until activated (thesis 3.2)."""

    name: str
    """Unique key in the catalogue."""
    title: str
    """What the operator sees in the list."""
    description: str
    options: tuple[OptionSpec, ...]

    def activate(self, options: Mapping[str, str]) -> None:
        """Validate ``options`` and get ready; a bad option raises :class:`GeneratorError`."""

    def generate(self) -> Script:
        """The activity's script (only once activated)."""

    def shutdown(self) -> None:
        """Back to quiescence."""


class GeneratorView(Message):
    """What a generator sees at generate time: a copy of the map (changing it changes
    nothing) and the simulated time."""

    world_map: WorldMap
    now_ms: int


class AwareGenerator(Generator, Protocol):
    """A generator that looks at the map and listens to rules (both optional hooks)."""

    def see(self, view: GeneratorView) -> None:
        """Called just before ``generate`` with the map as it is now."""

    def hear(self, note: GeneratorNote) -> None:
        """A rule's message addressed to this generator."""


class BaseGenerator:
    """Lifecycle shared by the shipped generators: subclasses write ``build(options)``.

    ``self.view`` is the latest map view (None before the first), ``self.state`` a dict
    the subclass may keep between scripts, ``self.heard`` the rules' messages so far.
    """

    name: str = ""
    title: str = ""
    description: str = ""
    options: tuple[OptionSpec, ...] = ()

    def __init__(self) -> None:
        self._values: dict[str, OptionValue] | None = None
        self.view: GeneratorView | None = None
        self.state: dict[str, object] = {}
        self.heard: list[GeneratorNote] = []

    def see(self, view: GeneratorView) -> None:
        self.view = view

    def hear(self, note: GeneratorNote) -> None:
        self.heard.append(note)

    @property
    def active(self) -> bool:
        return self._values is not None

    def activate(self, options: Mapping[str, str]) -> None:
        self._values = parse_options(self.options, options, source=self.name)

    def generate(self) -> Script:
        if self._values is None:
            raise GeneratorError("generate called before activate", source=self.name)
        return self.build(self._values)

    def shutdown(self) -> None:
        self._values = None

    def build(self, values: Mapping[str, OptionValue]) -> Script:
        """The script for these (validated, typed) option values."""
        raise NotImplementedError


class GeneratorInfo(Message):
    """A catalogue entry as a UI lists it."""

    name: str
    title: str
    description: str
    options: tuple[OptionSpec, ...] = ()


class Catalogue:
    """Generator factories by name; every selection gets a fresh instance."""

    def __init__(self, factories: Mapping[str, Callable[[], Generator]]):
        self._factories = dict(factories)
        self._infos: dict[str, GeneratorInfo] = {}
        for key, factory in self._factories.items():
            g = guarded(key, "create", factory)
            if g.name != key:
                raise GeneratorError(
                    f"catalogue key {key!r} makes a generator named {g.name!r}", source=key
                )
            self._infos[key] = GeneratorInfo(
                name=g.name, title=g.title, description=g.description, options=g.options
            )

    def names(self) -> tuple[str, ...]:
        """The generator names, in catalogue order."""
        return tuple(self._factories)

    def __contains__(self, name: object) -> bool:
        return name in self._factories

    def info(self, name: str) -> GeneratorInfo:
        """One entry; ``KeyError`` when unknown."""
        return self._infos[name]

    def create(self, name: str) -> Generator:
        """A fresh, quiescent generator; ``KeyError`` when unknown."""
        return self._factories[name]()

    def describe(self) -> tuple[GeneratorInfo, ...]:
        """Every generator with its options, in catalogue order (for the app's screens)."""
        return tuple(self._infos.values())

    def describe_json(self) -> bytes:
        """:meth:`describe` as JSON."""
        return msgspec.json.encode(self.describe())

    def with_factories(self, factories: Mapping[str, Callable[[], Generator]]) -> Catalogue:
        """A new catalogue with these generators appended (a name may not repeat)."""
        for name in factories:
            if name in self._factories:
                raise GeneratorError(
                    "a generator of this name is already in the catalogue", source=name
                )
        return Catalogue({**self._factories, **factories})


def guarded(name: str, what: str, call: Callable[..., _T], *args: object) -> _T:
    """``call(*args)``, the ``what`` of generator ``name`` (user code). What it raises
    other than a :class:`GeneratorError` becomes one: ``generator 'x': generate() raised
    KeyError: 'y' (mine.py:8)`` (file name and line only, the same on every machine)."""
    try:
        return call(*args)
    except GeneratorError:
        raise
    except FAILURES as error:
        raise failed(name, f"{what}() raised {failure(error)}") from None


class GeneratorFailure(GeneratorError):
    """A generator's code failed (it raised, overran, or made no valid script) rather than
    refusing with a :class:`GeneratorError` of its own: a bug, which a session logs at ERROR."""


def failed(name: str, what: str) -> GeneratorFailure:
    """A :class:`GeneratorFailure` saying that generator ``name`` failed at ``what``."""
    return GeneratorFailure(what, source=f"generator {name!r}")
