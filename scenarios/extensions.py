"""Extensions: user modules that add condition functions, rules, generators, behaviours and
activity folders through one registration API, and the per-session toolkit built from them.

An extension is a Python module or package with a ``register`` function::

    def register(ext: oimi.Extension) -> None:
        ext.function(pop_count)         # a function marked @boolean, @string or @evaluation
        ext.rule(PopReward)             # a Rule subclass, rule code >= USER_RULE_CODES
        ext.generator(BubblesGenerator) # a generator class (or factory) with a ``name``
        ext.behaviour("chase_bubbles", ChaseBubbles)  # a human behaviour factory
        ext.activities("activities")    # a folder of scripts, relative to the extension

Extensions come from a scenario's ``extensions = [...]`` (paths relative to the scenario
file, or module names), from ``--extension MODULE`` and from installed packages through
the entry-point group ``oimi.extensions``. :func:`build_toolkit` merges them with the
built-ins; a name or rule code that collides is refused naming both origins.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.util
import sys
import traceback
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from types import MappingProxyType, ModuleType
from typing import Final

import msgspec
from oimi.pipeline.errors import defined_at, named
from oimi.pipeline.operator.generators import default_catalogue
from oimi.pipeline.registries import GeneratorFactory, Registries
from oimi.pipeline.think.functions import spec_of
from oimi.pipeline.think.library import BUILTIN_RULES
from oimi.pipeline.think.rules import Rule, check_rule, check_writes
from oimi.pipeline.think.stdlib import default_registry
from oimi.scenarios.errors import ScenarioError
from oimi.scenarios.simulation.humans import BUILTIN_BEHAVIOURS, BehaviourFactory

ENTRY_POINT_GROUP: Final = "oimi.extensions"
"""Installed packages declare their extensions under this entry-point group."""
USER_RULE_CODES: Final = 1000
"""Extension rule codes start here; 0..999 belong to oimi's rule library."""
BUILTIN: Final = "oimi (built-in)"
ATTACHMENT_PREFIX: Final = "extensions/"
"""Where a recording keeps the extensions' sources: ``extensions/NAME/PATH``."""


class ExtensionError(ScenarioError):
    """An extension could not be loaded, or collides with another or with a built-in."""


@dataclass
class Extension:
    """The registration API handed to an extension's ``register(ext)``."""

    name: str
    root: Path
    """The extension's folder (``activities`` paths are relative to it)."""
    origin: str = ""
    """How it was named (a path or a module name): where its errors point."""
    functions: list[Callable[..., object]] = field(default_factory=list)
    rules: list[type[Rule]] = field(default_factory=list)
    generators: dict[str, GeneratorFactory] = field(default_factory=dict)
    behaviours: dict[str, BehaviourFactory] = field(default_factory=dict)
    activity_folders: list[Path] = field(default_factory=list)

    @property
    def label(self) -> str:
        """How messages name it: ``extension 'NAME' (FILE)``, the file by its base name."""
        return f"extension {self.name!r} ({Path(self.origin).name or self.name})"

    def _error(self, message: str) -> ExtensionError:
        """``message`` about this extension: it names the extension, and points at it."""
        return ExtensionError(f"{message} ({self.label})", source=self.origin or self.name)

    def function(self, fn: Callable[..., object]) -> Callable[..., object]:
        """Add a condition function marked with ``@boolean``, ``@string`` or ``@evaluation``."""
        spec_of(fn)  # refuses an unmarked function or a bad signature now, naming it
        self.functions.append(fn)
        return fn

    def rule(self, cls: type[Rule]) -> type[Rule]:
        """Add a rule class (its ``rulecode`` must be at least ``USER_RULE_CODES``, its
        ``writes`` a tuple of map parts). :func:`build_toolkit` checks its ``writes`` and
        ``condition_text`` as the session will, with every extension's functions."""
        if not (isinstance(cls, type) and issubclass(cls, Rule)):
            raise TypeError(f"{named(cls)} is not a Rule subclass")
        try:
            check_writes(cls)
        except ValueError as error:
            raise self._error(str(error)) from None
        self.rules.append(cls)
        return cls

    def generator(self, factory: GeneratorFactory) -> GeneratorFactory:
        """Add a script generator: a class (or factory) whose instances have a ``name``."""
        name = getattr(factory, "name", "") or factory().name
        if not (isinstance(name, str) and name):
            raise self._error(f'generator {named(factory)} has no name: give it one (name = "...")')
        if name in self.generators:
            raise self._error(f"generator {name!r} added twice")
        self.generators[name] = factory
        return factory

    def behaviour(self, name: str, factory: BehaviourFactory) -> BehaviourFactory:
        """Add a human behaviour, used in a scenario as ``{kind = "custom", name = ...}``."""
        if not (isinstance(name, str) and name):
            raise self._error(f"a behaviour's name must be a non-empty str, not {name!r}")
        if not callable(factory):
            raise self._error(f"behaviour {name!r}: {named(factory)} is not a class or function")
        if name in self.behaviours:
            raise self._error(f"behaviour {name!r} added twice")
        self.behaviours[name] = factory
        return factory

    def activities(self, folder: str | Path) -> None:
        """Add a folder of activity scripts (relative to the extension's folder)."""
        path = (self.root / folder).resolve()
        if not path.is_dir():
            raise self._error(f"activity folder {str(folder)!r} does not exist")
        self.activity_folders.append(path)


@dataclass(frozen=True)
class LoadedExtension:
    """An extension after ``register``: what it added and the sources it came from."""

    name: str
    version: str
    module: str
    """The module's import name."""
    origin: str
    """How it was named (a path, a module name, or ``entry point NAME``)."""
    sources: tuple[tuple[str, bytes], ...]
    """Its Python files (and activity scripts), by path relative to its folder, sorted."""
    added: Extension

    @property
    def digest(self) -> str:
        """Hash of the sources, to tell whether a replay runs the same code."""
        h = hashlib.sha256()
        for path, data in self.sources:
            h.update(path.encode() + b"\0" + hashlib.sha256(data).digest())
        return h.hexdigest()[:16]


def load_extension(spec: str, *, base: Path | None = None) -> LoadedExtension:
    """Import an extension named by a path (``.py`` file or package folder, relative to
    ``base``) or a module name, and run its ``register``."""
    module = _import(spec, base)
    register = getattr(module, "register", None)
    if not callable(register):
        raise ExtensionError(f"{spec!r} has no register(ext) function", source=spec)
    root = _root(module)
    ext = Extension(name=getattr(module, "NAME", module.__name__), root=root, origin=spec)
    try:
        register(ext)
    except ExtensionError:
        raise
    except Exception as error:  # an extension's bug is bad input, named, not a traceback
        home = root if Path(module.__file__ or "").name == "__init__.py" else _file(module)
        raise ExtensionError(
            f"extension {spec!r}: register failed: {type(error).__name__}: {error}"
            + _where(error, home),
            source=spec,
        ) from None
    return LoadedExtension(
        name=ext.name,
        version=str(getattr(module, "__version__", "0")),
        module=module.__name__,
        origin=spec,
        sources=_sources(module, root, ext.activity_folders),
        added=ext,
    )


def installed_extensions() -> list[LoadedExtension]:
    """Extensions of installed packages (entry-point group ``oimi.extensions``), by name."""
    found = []
    for point in sorted(metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda p: p.name):
        found.append(load_extension(point.value.partition(":")[0]))
    return found


@functools.cache
def installed_extension_packages() -> frozenset[str]:
    """The top-level packages of the installed extensions (their code is a user's, though
    it lives with the libraries); read once, when a watchdog first needs them."""
    points = metadata.entry_points(group=ENTRY_POINT_GROUP)
    return frozenset(point.value.partition(":")[0].partition(".")[0] for point in points)


def load_extensions(
    specs: Sequence[str], *, base: Path | None = None, installed: bool = True
) -> tuple[LoadedExtension, ...]:
    """``specs`` loaded (relative to ``base``), then the installed ones, each module once
    (two with one module name and different sources: :class:`ExtensionError`)."""
    return _each_module_once(
        [
            *(load_extension(s, base=base) for s in specs),
            *(installed_extensions() if installed else []),
        ]
    )


def _each_module_once(extensions: Iterable[LoadedExtension]) -> tuple[LoadedExtension, ...]:
    """The first of each module name; another of that name must have the same sources (the
    same extension named twice), for one import name cannot hold two extensions."""
    unique: dict[str, LoadedExtension] = {}
    for ext in extensions:
        kept = unique.setdefault(ext.module, ext)
        if kept.digest != ext.digest:
            raise ExtensionError(
                f"extensions {kept.origin!r} and {ext.origin!r} both import as module"
                f" {ext.module!r} but are different code: rename one",
                source=ext.origin,
            )
    return tuple(unique.values())


@dataclass(frozen=True)
class Toolkit:
    """Everything a session may call by name: the pipeline's registries, the simulated
    humans' behaviours, the extra activity folders, and the extensions they came from."""

    registries: Registries
    behaviours: Mapping[str, BehaviourFactory]
    activity_folders: tuple[Path, ...] = ()
    extensions: tuple[LoadedExtension, ...] = ()


def build_toolkit(extensions: Iterable[LoadedExtension] = ()) -> Toolkit:
    """The built-ins plus ``extensions`` (one module counted once); a colliding name, rule
    code or module name raises :class:`ExtensionError` naming both origins."""
    extensions = _each_module_once(extensions)
    functions = {name: BUILTIN for name in default_registry().names()}
    rules = {cls.rulecode: f"{cls.__name__} ({BUILTIN})" for cls in BUILTIN_RULES}
    generators = {name: BUILTIN for name in default_catalogue().names()}
    behaviours: dict[str, str] = {name: BUILTIN for name in BUILTIN_BEHAVIOURS}
    for ext in extensions:
        added, origin, source = ext.added, ext.added.label, ext.origin
        for fn in added.functions:
            where = defined_at(fn)  # its def's line, for the author to rename it
            mine = f"{origin} ({where})" if where else origin
            _claim(functions, spec_of(fn).name, mine, "function", source=source)
        for cls in added.rules:
            _claim(rules, cls.rulecode, f"{cls.__name__} ({origin})", "rule code", source=source)
            if cls.rulecode < USER_RULE_CODES:
                raise added._error(
                    f"rule code {cls.rulecode} of {cls.__name__} is in oimi's range:"
                    f" extension rule codes start at {USER_RULE_CODES}"
                )
        for name in added.generators:
            _claim(generators, name, origin, "generator", source=source)
        for name in added.behaviours:
            _claim(behaviours, name, origin, "behaviour", source=source)
    added_functions = [fn for ext in extensions for fn in ext.added.functions]
    try:
        registries = Registries.build(
            functions=added_functions,
            rules=[cls for ext in extensions for cls in ext.added.rules],
            generators={k: v for ext in extensions for k, v in ext.added.generators.items()},
        )
    except ValueError:  # a rule's writes or condition_text: say whose
        _check_rules(extensions, added_functions)
        raise  # none of theirs: oimi's own rules are wrong
    return Toolkit(
        registries=registries,
        behaviours=MappingProxyType(
            {k: v for ext in extensions for k, v in ext.added.behaviours.items()}
        ),
        activity_folders=tuple(p for ext in extensions for p in ext.added.activity_folders),
        extensions=extensions,
    )


def extensions_metadata(extensions: Iterable[LoadedExtension]) -> dict[str, str]:
    """The ``extensions`` metadata record: per extension, its module, version and digest."""
    return {
        ext.name: msgspec.json.encode(
            {"module": ext.module, "version": ext.version, "digest": ext.digest}
        ).decode()
        for ext in extensions
    }


def extension_attachments(extensions: Iterable[LoadedExtension]) -> list[tuple[str, bytes]]:
    """Every extension's sources as attachments ``extensions/NAME/PATH``."""
    return [
        (f"{ATTACHMENT_PREFIX}{ext.name}/{path}", data)
        for ext in extensions
        for path, data in ext.sources
    ]


def _check_rules(
    extensions: Iterable[LoadedExtension], functions: Sequence[Callable[..., object]]
) -> None:
    """Check each extension's rules on their own, as the session's :class:`RuleRegistry`
    does; the first it refuses raises an :class:`ExtensionError` naming its extension."""
    registry = Registries.build(functions=functions).functions
    for ext in extensions:
        for cls in ext.added.rules:
            try:
                check_rule(cls, functions=registry)
            except ValueError as error:
                raise ext.added._error(str(error)) from None


def _claim(taken: dict, key: object, origin: str, what: str, *, source: str) -> None:
    """Take ``key`` for ``origin``; one taken already raises, naming both (``source``:
    where the error points, the extension that came second)."""
    if key in taken:
        raise ExtensionError(
            f"{what} {key!r} of {origin} collides with {taken[key]}", source=source
        )
    taken[key] = origin


def _import(spec: str, base: Path | None) -> ModuleType:
    looks_like_path = spec.endswith(".py") or "/" in spec or spec.startswith(".")
    path = (base / spec if base is not None else Path(spec)) if looks_like_path else None
    if path is None and base is not None and (base / spec).exists():
        path = base / spec
    if path is None:
        try:
            return importlib.import_module(spec)
        except ImportError as error:
            raise ExtensionError(
                f"cannot import extension {spec!r}: {error}", source=spec
            ) from None
    path = path.resolve()
    init = path / "__init__.py" if path.is_dir() else path
    if not init.is_file():
        raise ExtensionError(f"extension {spec!r} not found at {path}", source=spec)
    name = path.name if path.is_dir() else path.stem
    for loaded in [m for m in sys.modules if m == name or m.startswith(name + ".")]:
        del sys.modules[loaded]  # always the file's current code (a replay's attached sources)
    locations = [str(path)] if path.is_dir() else None
    module_spec = importlib.util.spec_from_file_location(
        name, init, submodule_search_locations=locations
    )
    if module_spec is None or module_spec.loader is None:
        raise ExtensionError(f"cannot import extension {spec!r}", source=spec)
    module = importlib.util.module_from_spec(module_spec)
    sys.modules[name] = module  # a package's own relative imports find it
    try:
        module_spec.loader.exec_module(module)
    except Exception as error:
        del sys.modules[name]
        where = "" if isinstance(error, SyntaxError) else _where(error, path)  # it says where
        raise ExtensionError(
            f"extension {spec!r} failed to import: {type(error).__name__}: {error}{where}",
            source=spec,
        ) from None
    return module


def _file(module: ModuleType) -> Path:
    return Path(module.__file__ or ".").resolve()


def _root(module: ModuleType) -> Path:
    return _file(module).parent


def _where(error: BaseException, home: Path) -> str:
    """`` (rules.py:8)``: the innermost line of the extension's own code (``home``: its
    file, or its package's folder) that ``error`` came through; empty when none."""
    lines = [
        (Path(frame.f_code.co_filename), line)
        for frame, line in traceback.walk_tb(error.__traceback__)
    ]
    if home.is_dir():
        mine = [(f.relative_to(home).as_posix(), n) for f, n in lines if f.is_relative_to(home)]
    else:
        mine = [(f.name, n) for f, n in lines if f == home]
    return f" ({mine[-1][0]}:{mine[-1][1]})" if mine else ""


def _sources(
    module: ModuleType, root: Path, folders: Iterable[Path]
) -> tuple[tuple[str, bytes], ...]:
    file = Path(module.__file__ or "").resolve()
    is_package = file.name == "__init__.py"
    files = sorted(root.rglob("*.py")) if is_package else [file]
    files = [f for f in files if "__pycache__" not in f.parts]
    for folder in folders:
        files += sorted(p for p in folder.rglob("*") if p.suffix in (".json", ".txt"))
    out = {}
    for f in files:
        rel = (
            f.resolve().relative_to(root).as_posix() if f.resolve().is_relative_to(root) else f.name
        )
        out[rel] = f.read_bytes()
    return tuple(sorted(out.items()))


__all__ = [
    "ENTRY_POINT_GROUP",
    "USER_RULE_CODES",
    "Extension",
    "ExtensionError",
    "LoadedExtension",
    "Toolkit",
    "build_toolkit",
    "load_extension",
    "load_extensions",
]
