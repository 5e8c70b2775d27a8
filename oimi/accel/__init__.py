"""Compiled hot modules: the modules a session spends its time in, compiled unchanged with
Cython, each loaded only while its source is exactly the source it was compiled from.

``make env`` builds them (``python -m oimi.accel``) when Cython and a C compiler are
there. A compiled module is kept under the environment (``sys.prefix/oimi-accel``, or
``$OIMI_ACCEL_DIR``) in a file named for its source's SHA-256, and :class:`CompiledFinder`
loads it only for that source: an edited module runs as Python until it is built again,
never stale. ``OIMI_PURE=1`` runs everything as Python (a profiler then sees every
function). The code is compiled without C types (``annotation_typing=False``): every
operation keeps Python's semantics, so a session gives the same messages, bit for bit,
compiled or not (the goldens are checked both ways). The classes :data:`EXTENSION_TYPES`
lists become extension types (:mod:`.declarations`): their attributes are C fields.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import os
import sys
import tempfile
import time
import types
import warnings
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Final

from oimi.accel.declarations import DeclarationError, declarations

MODULES: Final = (
    "oimi.pipeline.loop",
    "oimi.pipeline.sink",
    "oimi.pipeline.jsontree",
    "oimi.pipeline.mapdeltas",
    "oimi.pipeline.proximity",
    "oimi.pipeline.act.actuator",
    "oimi.pipeline.act.channels",
    "oimi.pipeline.act.echoes",
    "oimi.pipeline.act.limits",
    "oimi.pipeline.act.looking",
    "oimi.pipeline.act.reckoning",
    "oimi.pipeline.act.safety",
    "oimi.pipeline.act.separation",
    "oimi.pipeline.operator.handler",
    "oimi.pipeline.sense.producer",
    "oimi.pipeline.sense.updates",
    "oimi.pipeline.think.chain",
    "oimi.pipeline.think.condition_compile",
    "oimi.pipeline.think.condition_runtime",
    "oimi.pipeline.think.episodes",
    "oimi.pipeline.think.mapparts",
    "oimi.pipeline.think.reader",
    "oimi.pipeline.think.rules",
    "oimi.pipeline.think.stdlib",
    "oimi.scenarios.simulation.bodies",
    "oimi.scenarios.simulation.humans",
    "oimi.scenarios.simulation.sensors",
    "oimi.scenarios.simulation.world",
    "oimi.scenarios.session.expectations",
    "oimi.scenarios.session.runner",
    "oimi.recorder.foxglove",
    "oimi.recorder.mcap_sink",
    "oimi.recorder.scan",
    "oimi.replay.compare",
    "oimi.replay.redrive",
)
"""The modules compiled: where a recorded session and a redrive spend most of their time
(profiled). A module whose source is read while oimi runs stays Python:
``oimi.pipeline.think.library`` is attached to every recording as ``rules/library.py``."""
EXTENSION_TYPES: Final[dict[str, tuple[str, ...]]] = {
    "oimi.pipeline.loop": ("Pipeline", "_Emitter"),
    "oimi.pipeline.sink": ("FanOut",),
    "oimi.pipeline.mapdeltas": ("MapDeltas",),
    "oimi.pipeline.proximity": ("ProximityTracker",),
    "oimi.pipeline.act.actuator": ("Actuator",),
    "oimi.pipeline.act.channels": ("ChannelCursor",),
    "oimi.pipeline.act.echoes": ("EchoSorter",),
    "oimi.pipeline.act.looking": ("SensorWatch",),
    "oimi.pipeline.act.reckoning": ("DeadReckoning",),
    "oimi.pipeline.act.safety": ("SafetySupervisor",),
    "oimi.pipeline.operator.handler": ("GeneratorHandler",),
    "oimi.pipeline.sense.producer": ("MapProducer", "_Index"),
    "oimi.pipeline.think.chain": ("RuleChain",),
    "oimi.pipeline.think.condition_runtime": ("Run", "Condition"),
    "oimi.pipeline.think.mapparts": ("MapParts",),
    "oimi.pipeline.think.reader": ("ReadOutcome", "BlockReader"),
    "oimi.pipeline.think.rules": ("Memo",),
    "oimi.scenarios.simulation.bodies": ("Mover", "Robot", "Human", "Thing", "BodyReader"),
    "oimi.scenarios.simulation.humans": ("HumanDriver",),
    "oimi.scenarios.simulation.sensors": ("Schedule", "_Sensor", "Sensors"),
    "oimi.scenarios.simulation.world": ("World",),
    "oimi.scenarios.session.expectations": ("Tracker",),
    "oimi.scenarios.session.runner": ("Session",),
    "oimi.recorder.foxglove": ("Views",),
    "oimi.recorder.mcap_sink": ("McapSink", "_MessageWriter"),
    "oimi.recorder.scan": ("_Body", "ChunkScan"),
    "oimi.replay.compare": ("Comparator",),
}
"""The classes each compiled module builds as extension types (:mod:`.declarations`): their
methods reach ``self``'s attributes directly. Compiled, their instances take no attribute
their methods do not assign and the classes cannot be patched. None is a class users
extend (rules, generators, behaviours); a subclass here must not give a class-level name
(constant, method, property) to one of their attributes (tests/packaging checks)."""
PURE_ENV: Final = "OIMI_PURE"
DIR_ENV: Final = "OIMI_ACCEL_DIR"
DIRECTIVES: Final = {"annotation_typing": False, "binding": True, "language_level": 3}
"""Untyped (Python objects throughout, Python's arithmetic), functions that introspect."""
SUFFIX: Final = importlib.machinery.EXTENSION_SUFFIXES[0]


def pure() -> bool:
    """Whether ``OIMI_PURE`` asks for Python only."""
    return os.environ.get(PURE_ENV, "") not in ("", "0")


def accel_dir() -> Path:
    """Where compiled modules are kept (per environment: they fit its interpreter)."""
    return Path(os.environ.get(DIR_ENV) or Path(sys.prefix) / "oimi-accel")


def compiled_path(name: str, source: Path, folder: Path) -> Path:
    """The compiled module for ``name`` built from ``source`` exactly as it is now (and
    with the extension types :data:`EXTENSION_TYPES` lists for it)."""
    text = source.read_bytes()
    if classes := EXTENSION_TYPES.get(name):
        text += "\0extension types: {}\0".format(" ".join(classes)).encode() + _declarer()
    digest = hashlib.sha256(text).hexdigest()[:24]
    return folder / f"{name}.{digest}{SUFFIX}"


@functools.cache
def _declarer() -> bytes:
    """The source of :mod:`.declarations` (a module with extension types is built again
    when the way its declarations are derived changes)."""
    return Path(__file__).with_name("declarations.py").read_bytes()


def source_of(name: str, path: Sequence[str] | None = None) -> Path | None:
    """The ``.py`` file ``name`` would be imported from (``path``: its package's path)."""
    if path is None:
        path = importlib.import_module(name.rpartition(".")[0]).__path__
    spec = importlib.machinery.PathFinder.find_spec(name, path)
    origin = spec.origin if spec is not None else None
    return Path(origin) if origin and origin.endswith(".py") else None


class CompiledFinder(importlib.abc.MetaPathFinder):
    """Finds a compiled module for each of ``modules`` whose source it was built from."""

    def __init__(self, folder: Path, modules: Iterable[str] = MODULES) -> None:
        self.folder = folder
        self.modules = frozenset(modules)

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: object = None
    ) -> importlib.machinery.ModuleSpec | None:
        if fullname not in self.modules or path is None:
            return None
        source = source_of(fullname, path)
        if source is None:
            return None
        compiled = compiled_path(fullname, source, self.folder)
        if not compiled.is_file():
            return None
        loader = CompiledLoader(fullname, compiled, source)
        return importlib.util.spec_from_file_location(fullname, compiled, loader=loader)


class CompiledLoader(importlib.machinery.ExtensionFileLoader):
    """Loads a compiled module, or its source, with a warning, if the compiled file cannot
    be loaded (damaged, built for another interpreter): oimi still starts."""

    def __init__(self, name: str, compiled: Path, source: Path) -> None:
        super().__init__(name, str(compiled))
        self.source = source
        self._instead: importlib.machinery.SourceFileLoader | None = None

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType | None:
        try:
            return super().create_module(spec)
        except ImportError as error:
            warnings.warn(
                f"{self.path} not loaded ({error}); {self.name} runs as Python"
                " (make accel builds it again)",
                RuntimeWarning,
                stacklevel=2,
            )
            self._instead = importlib.machinery.SourceFileLoader(self.name, str(self.source))
            spec.origin = str(self.source)  # the module's __file__
            return None

    def exec_module(self, module: types.ModuleType) -> None:
        if self._instead is None:
            super().exec_module(module)
        else:
            self._instead.exec_module(module)


def install() -> CompiledFinder | None:
    """Put a :class:`CompiledFinder` first on ``sys.meta_path`` (once), unless pure."""
    if pure():
        return None
    for finder in sys.meta_path:
        if isinstance(finder, CompiledFinder):
            return finder
    folder = accel_dir()
    if not folder.is_dir():
        return None
    finder = CompiledFinder(folder)
    sys.meta_path.insert(0, finder)
    return finder


def compiled_modules() -> list[str]:
    """The modules running compiled in this process."""
    return [
        m for m in MODULES if (getattr(sys.modules.get(m), "__file__", "") or "").endswith(SUFFIX)
    ]


def ready(folder: Path | None = None) -> list[str]:
    """The modules that a new process would run compiled (none when pure)."""
    if pure():
        return []
    folder = folder or accel_dir()
    found = []
    for name in MODULES:
        source = source_of(name)
        if source is not None and compiled_path(name, source, folder).is_file():
            found.append(name)
    return found


def build(
    folder: Path, modules: Iterable[str] = MODULES, *, say: Callable[[str], None] = print
) -> list[str]:
    """Compile each of ``modules`` whose current source has no compiled module in
    ``folder`` yet; drop compiled modules of older sources. Returns the names compiled; a
    module Cython cannot translate is said and left as Python. Needs Cython and a C
    compiler (``ImportError`` or a build error otherwise)."""
    from Cython.Build import cythonize
    from Cython.Compiler.Errors import CompileError
    from setuptools import Distribution, Extension

    folder.mkdir(parents=True, exist_ok=True)
    wanted = {name: source_of(name) for name in modules}
    todo = {}
    for name, source in wanted.items():
        if source is None:
            raise FileNotFoundError(f"no Python source for {name}")
        target = compiled_path(name, source, folder)
        for old in folder.glob(f"{name}.*{SUFFIX}"):
            if old != target:
                old.unlink(missing_ok=True)  # another build may have dropped it
        if not target.is_file():
            todo[name] = (source, target)
    if not todo:
        return []
    say(f"compiling {len(todo)} module(s) with Cython into {folder} (about 2 s each)")
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="oimi-accel-") as work:
        include = Path(work) / "include"
        compiled = []
        for name, (source, _) in list(todo.items()):
            extension = Extension(name, [str(source)], extra_compile_args=["-w"])  # no advice
            try:
                _declare(name, source, include)
            except DeclarationError as error:
                say(f"left as Python: {name} ({error})")
                del todo[name]
                continue
            try:
                compiled += cythonize(
                    [extension],
                    compiler_directives=DIRECTIVES,
                    build_dir=work,
                    include_path=[str(include)],
                    quiet=True,
                )
            except CompileError:
                say(f"left as Python: {name} (Cython cannot translate it; see above)")
                del todo[name]
        if not todo:
            return []
        dist = Distribution({"name": "oimi-accel", "ext_modules": compiled})
        command = dist.get_command_obj("build_ext")
        command.build_lib = str(Path(work) / "lib")
        command.build_temp = str(Path(work) / "temp")
        command.parallel = os.cpu_count() or 1
        cwd = os.getcwd()
        os.chdir(work)  # setuptools reads the current folder's configuration
        try:
            dist.run_command("build_ext")
        finally:
            os.chdir(cwd)
        for name, (_, target) in todo.items():
            built = Path(command.get_ext_fullpath(name))
            built.replace(target)
    say(f"compiled {len(todo)} module(s) in {time.monotonic() - started:.0f} s")
    return list(todo)


def _declare(name: str, source: Path, include: Path) -> None:
    """Write the module's declarations (:data:`EXTENSION_TYPES`), if it has any, as
    ``include/oimi/.../module.pxd``: Cython looks them up by the module's full name, which
    the source tree does not spell (the package ``oimi`` maps onto the top folders)."""
    if classes := EXTENSION_TYPES.get(name):
        target = include.joinpath(*name.split(".")).with_suffix(".pxd")
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(declarations(source.read_text(), classes, filename=str(source)))
