"""The compiled hot modules: loaded only for the source they were built from, the same
results as Python (the goldens both ways), and really used where they were built; their
extension types: declared from the classes' source, built as such."""

from __future__ import annotations

import ast
import importlib
import importlib.machinery
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from oimi import accel
from oimi.accel.declarations import DeclarationError, assigned_attributes, declarations

ROOT = Path(__file__).resolve().parents[2]
REQUIRED = os.environ.get("OIMI_REQUIRE_ACCEL", "") not in ("", "0")
"""CI sets it: a build that silently fell back to Python would not show as skipped tests."""


def _package(tmp_path: Path, name: str, source: str) -> Path:
    package = tmp_path / name
    package.mkdir()
    (package / "__init__.py").write_text("")
    module = package / "tiny.py"
    module.write_text(source)
    return module


def _importable(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str) -> Path:
    """A package ``name`` with a module ``tiny`` on ``sys.path``; the module's file."""
    monkeypatch.syspath_prepend(str(tmp_path))
    return _package(tmp_path, name, "def twice(x):\n    return 2 * x\n")


def _finding_first(monkeypatch: pytest.MonkeyPatch, folder: Path, name: str) -> None:
    finder = accel.CompiledFinder(folder, modules=[name])
    monkeypatch.setattr(sys, "meta_path", [finder, *sys.meta_path])


def test_a_compiled_module_is_found_only_for_the_source_it_was_built_from(tmp_path: Path) -> None:
    module = _package(tmp_path, "accel_probe", "def twice(x):\n    return 2 * x\n")
    folder = tmp_path / "compiled"
    folder.mkdir()
    finder = accel.CompiledFinder(folder, modules=["accel_probe.tiny"])
    path = [str(module.parent)]
    assert finder.find_spec("accel_probe.tiny", path) is None, "nothing built yet"
    built = accel.compiled_path("accel_probe.tiny", module, folder)
    built.touch()
    spec = finder.find_spec("accel_probe.tiny", path)
    assert spec is not None and spec.origin == str(built)
    assert isinstance(spec.loader, importlib.machinery.ExtensionFileLoader)
    assert finder.find_spec("accel_probe.other", path) is None, "not one of its modules"
    module.write_text("def twice(x):\n    return x + x\n")  # edited since it was built
    assert finder.find_spec("accel_probe.tiny", path) is None, "an edited module runs as Python"


def test_oimi_pure_installs_no_finder(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(accel.PURE_ENV, "1")
    assert accel.install() is None
    assert accel.ready() == []


def _can_compile() -> bool:
    try:
        import Cython  # noqa: F401
        import setuptools  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.mark.skipif(not (REQUIRED or _can_compile()), reason="Cython is not installed")
def test_a_module_is_built_loaded_compiled_and_rebuilt_when_edited(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    module = _importable(tmp_path, monkeypatch, "accel_built")
    folder = tmp_path / "compiled"
    name = "accel_built.tiny"
    assert accel.build(folder, [name], say=lambda line: None) == [name]
    assert accel.build(folder, [name], say=lambda line: None) == [], "up to date"
    _finding_first(monkeypatch, folder, name)
    tiny = importlib.import_module(name)
    assert tiny.__file__.endswith(accel.SUFFIX) and tiny.twice(21) == 42
    module.write_text("def twice(x):\n    return x + x\n")
    assert accel.build(folder, [name], say=lambda line: None) == [name]
    assert len(list(folder.glob(f"{name}.*"))) == 1, "the older source's build is dropped"
    # Cython 3.3 cannot translate a starred tuple of exception types: left as Python, said
    module.write_text("E = (OSError,)\ntry:\n    pass\nexcept (*E, KeyError):\n    pass\n")
    said: list[str] = []
    assert accel.build(folder, [name], say=said.append) == []
    assert said[-1].startswith(f"left as Python: {name}")
    assert list(folder.glob(f"{name}.*")) == []


def test_python_alone_gives_the_goldens_too() -> None:
    """The suite runs compiled where the modules were built; Python alone must give the
    same recordings, byte for byte."""
    done = subprocess.run(
        [sys.executable, "-m", "oimi.replay.golden", "--check"],
        cwd=ROOT,
        env={**os.environ, accel.PURE_ENV: "1"},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stdout + done.stderr


@pytest.mark.skipif(not (REQUIRED or accel.ready()), reason="the hot modules are not compiled")
def test_where_they_were_built_the_hot_modules_run_compiled() -> None:
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            "import importlib; from oimi import accel;"
            "[importlib.import_module(m) for m in accel.MODULES];"
            "print(len(accel.compiled_modules()))",
        ],
        cwd=ROOT,
        env={k: v for k, v in os.environ.items() if k != accel.PURE_ENV},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.stdout.split() == [str(len(accel.MODULES))], done.stderr


def test_without_cython_the_build_says_so_and_oimi_runs_as_python(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from oimi.accel.__main__ import main

    monkeypatch.setitem(sys.modules, "Cython", None)  # import Cython raises ImportError
    monkeypatch.setitem(sys.modules, "Cython.Build", None)
    assert main(["--dir", str(tmp_path), "--optional"]) == 0  # make env goes on
    said = capsys.readouterr().err
    assert "not compiled (ModuleNotFoundError" in said and "runs as pure Python" in said
    assert main(["--dir", str(tmp_path)]) == 1
    assert list(tmp_path.iterdir()) == []


def test_a_compiled_file_that_cannot_be_loaded_leaves_its_source_running(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    module = _importable(tmp_path, monkeypatch, "accel_damaged")
    folder = tmp_path / "compiled"
    folder.mkdir()
    damaged = accel.compiled_path("accel_damaged.tiny", module, folder)
    damaged.write_bytes(b"not a shared object")
    _finding_first(monkeypatch, folder, "accel_damaged.tiny")
    with pytest.warns(RuntimeWarning, match=r"not loaded .*accel_damaged.tiny runs as Python"):
        tiny = importlib.import_module("accel_damaged.tiny")
    assert tiny.twice(21) == 42 and tiny.__file__ == str(module)


@pytest.mark.skipif(not (REQUIRED or accel.ready()), reason="the hot modules are not compiled")
def test_compiled_and_as_python_a_session_writes_the_same_file(tmp_path: Path) -> None:
    """Every topic, Foxglove's views included (the goldens hold only oimi's own topics)."""
    files = []
    for pure in ("0", "1"):
        out = tmp_path / f"pure{pure}.mcap"
        run = ["run", "scenarios/library/busy_playroom.toml", "-o", str(out), "-q"]
        done = subprocess.run(
            [sys.executable, "-m", "oimi", *run],
            cwd=ROOT,
            env={**os.environ, accel.PURE_ENV: pure},
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert done.returncode == 0, done.stdout + done.stderr
        files.append(out.read_bytes())
    assert files[0] == files[1]


# ------------------------------------------------------------------ extension types

SOURCE = """
class Base:
    def __init__(self):
        self.a = 1
        self.b: int = 2

class Counter(Base):
    kind = "counter"

    def __init__(self):
        super().__init__()
        self.count, (self.first, *self.rest) = 0, (1, 2, 3)
        self.a = 5  # the base's: not declared again

    def add(self, key):
        self.count += 1
        self.seen[key] = 1  # not an assignment of `seen`
        self.item().value = 2  # nor of `item`
        self.table.row = 3  # nor of `table`

class Loose:
    pass

class Other(Loose, Base):
    pass
"""

TYPED = """
class Base:
    def __init__(self):
        self.a = 1

class Counter(Base):
    kind = "counter"

    def __init__(self):
        super().__init__()
        self.count, self.seen, self.a = 0, {}, 5

    def add(self, key):
        self.count += 1
        self.seen[key] = 1

class Loose:
    pass
"""


def test_each_attribute_a_class_assigns_on_self_is_declared_once() -> None:
    assert declarations(SOURCE, ["Base", "Counter"]) == (
        "cdef class Base:\n"
        "    cdef public object a, b\n"
        "cdef class Counter(Base):\n"
        "    cdef public object count, first, rest\n"
    )
    assert declarations(SOURCE, ["Loose"]) == "cdef class Loose:\n    pass\n"


@pytest.mark.parametrize(
    ("classes", "says"),
    [
        (["Missing"], "no class Missing"),
        (["Counter"], "class Counter(Base): an extension type derives"),  # its base not listed
        (["Counter", "Base"], "class Counter(Base)"),  # listed after it
        (["Loose", "Base", "Other"], "class Other(Loose, Base)"),  # two bases
    ],
)
def test_a_class_that_cannot_be_an_extension_type_is_refused(classes, says) -> None:
    with pytest.raises(DeclarationError, match=r"^x\.py:(\d+: )?.*" + re.escape(says)):
        declarations(SOURCE, classes, filename="x.py")


def test_every_listed_class_can_be_declared_from_its_source() -> None:
    for module, classes in accel.EXTENSION_TYPES.items():
        assert module in accel.MODULES, f"{module} is not compiled"
        source = accel.source_of(module)
        assert source is not None
        text = declarations(source.read_text(), classes, filename=str(source))
        assert text.count("cdef class") == len(classes)


@pytest.mark.skipif(not (REQUIRED or _can_compile()), reason="Cython is not installed")
def test_a_listed_class_is_built_as_an_extension_type(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    package = tmp_path / "accel_typed"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "tiny.py").write_text(TYPED)
    monkeypatch.syspath_prepend(str(tmp_path))
    name = "accel_typed.tiny"
    folder = tmp_path / "compiled"
    assert accel.build(folder, [name], say=lambda line: None) == [name]
    plain = accel.compiled_path(name, package / "tiny.py", folder)
    monkeypatch.setitem(accel.EXTENSION_TYPES, name, ("Base", "Counter"))
    typed = accel.compiled_path(name, package / "tiny.py", folder)
    assert typed != plain, "the list of extension types is part of what a build is for"
    assert accel.build(folder, [name], say=lambda line: None) == [name]
    monkeypatch.setattr(sys, "meta_path", [accel.CompiledFinder(folder, [name]), *sys.meta_path])
    tiny = importlib.import_module(name)
    assert tiny.__file__ == str(typed)
    counter = tiny.Counter()
    counter.add("k")
    assert (counter.count, counter.a, counter.seen, counter.kind) == (1, 5, {"k": 1}, "counter")
    assert tiny.Counter.__dictoffset__ == 0, "its instances have no __dict__"
    with pytest.raises(AttributeError):
        counter.undeclared = 1
    assert hasattr(tiny.Loose(), "__dict__"), "an unlisted class stays a Python class"
    monkeypatch.setitem(accel.EXTENSION_TYPES, name, ("Base", "Counter", "Gone"))
    said: list[str] = []
    assert accel.build(folder, [name], say=said.append) == [], "a class renamed: left as Python"
    assert said[-1].startswith(f"left as Python: {name} (") and "no class Gone" in said[-1]


@pytest.mark.skipif(not (REQUIRED or accel.ready()), reason="the hot modules are not compiled")
def test_where_they_were_built_the_listed_classes_are_extension_types() -> None:
    probe = (
        "import importlib; from oimi import accel\n"
        "for module, classes in accel.EXTENSION_TYPES.items():\n"
        "    m = importlib.import_module(module)\n"
        "    for c in classes:\n"
        "        print(module, c, getattr(m, c).__dictoffset__)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe],
        cwd=ROOT,
        env={k: v for k, v in os.environ.items() if k != accel.PURE_ENV},
        capture_output=True,
        text=True,
        timeout=120,
    )
    lines = done.stdout.splitlines()
    assert len(lines) == sum(map(len, accel.EXTENSION_TYPES.values())), done.stderr
    assert [line for line in lines if not line.endswith(" 0")] == [], "not extension types"


def test_no_subclass_of_an_extension_type_shadows_one_of_its_attributes() -> None:
    """A class-level name (a constant, a method, a property) in a Python subclass with the
    name of an attribute its extension-type base declares would split the attribute in two:
    Python would read the subclass's, the compiled base its own field."""
    declared: dict[str, set[str]] = {}
    for module, classes in accel.EXTENSION_TYPES.items():
        source = accel.source_of(module)
        assert source is not None
        tree = ast.parse(source.read_text())
        tops = {n.name: n for n in tree.body if isinstance(n, ast.ClassDef)}
        for name in classes:
            declared[name] = set(assigned_attributes(tops[name]))
    subclasses = 0
    for path in ROOT.glob("**/*.py"):
        if {".venv", "build", "tests"} & set(path.relative_to(ROOT).parts):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.ClassDef):
                continue
            bases = {ast.unparse(b).rpartition(".")[2] for b in node.bases} & declared.keys()
            if not bases or node.name in declared:
                continue
            subclasses += 1
            names = {name for statement in node.body for name in _class_level_names(statement)}
            clashes = names & set().union(*(declared[b] for b in bases))
            assert not clashes, f"{path}: {node.name} shadows {sorted(clashes)}"
    assert subclasses >= 2, "LiveSession and SimSession at least"


def _class_level_names(statement: ast.stmt) -> list[str]:
    if isinstance(statement, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
        return [statement.name]
    targets = statement.targets if isinstance(statement, ast.Assign) else []
    if isinstance(statement, ast.AnnAssign | ast.AugAssign):
        targets = [statement.target]
    return [t.id for t in targets if isinstance(t, ast.Name)]
