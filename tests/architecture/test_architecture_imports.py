"""The package rules of docs/architecture.md, checked by walking every module's imports."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("pipeline", "scenarios", "recorder", "replay", "analysis", "oimi")
ALLOWED = {
    "pipeline": {"pipeline"},
    "recorder": {"pipeline", "recorder"},
    "scenarios": {"pipeline", "recorder", "scenarios"},
    "replay": {"pipeline", "recorder", "scenarios", "replay"},
    "analysis": {"recorder", "analysis", "pipeline"},
    "oimi": set(PACKAGES),
}
THIRD_PARTY_IN_CORE = {"msgspec", "lark"}
THIRD_PARTY: dict[str, set[str]] = {
    "pipeline": THIRD_PARTY_IN_CORE,
    # mcap, rerun-sdk; zstandard is MCAP's chunk codec, foxglove the live MCAP stream.
    "recorder": {"msgspec", "mcap", "rerun", "zstandard", "foxglove"},
    "scenarios": {"msgspec", "pymunk"},
    "replay": {"msgspec"},
    # polars; pyarrow is its Arrow layer, matplotlib draws the report's plots.
    "analysis": {"msgspec", "polars", "pyarrow", "matplotlib"},
}
"""The libraries each package may import besides the standard library (the table in
docs/architecture.md); ``oimi`` may import anything."""
FORBIDDEN_IN_CORE = {"threading", "asyncio", "random", "time", "datetime", "multiprocessing"}


FOLDERS = tuple(p for p in PACKAGES if p != "oimi")
"""The repository's top-level folders, installed as ``oimi.<folder>`` (one import name)."""


def raw_imports(path: Path) -> list[tuple[int, str]]:
    """Every absolute import of a module, as written."""
    tree = ast.parse(path.read_text(), filename=str(path))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.append((node.lineno, node.module))
    return found


def imported_modules(path: Path) -> list[tuple[int, str]]:
    """Every absolute import, with ``oimi.pipeline.x`` read as the folder's ``pipeline.x``."""
    found = []
    for line, name in raw_imports(path):
        head, _, rest = name.partition(".")
        if head == "oimi" and rest.split(".")[0] in FOLDERS:
            name = rest
        found.append((line, name))
    return found


def modules_of(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


@pytest.mark.parametrize("package", PACKAGES)
def test_packages_import_only_what_design_allows(package: str) -> None:
    broken = [
        f"{path.relative_to(ROOT)}:{line}: imports {name}"
        for path in modules_of(package)
        for line, name in imported_modules(path)
        if name.split(".")[0] in PACKAGES and name.split(".")[0] not in ALLOWED[package]
    ]
    assert not broken, "\n".join(broken)


@pytest.mark.parametrize("package", sorted(THIRD_PARTY))
def test_packages_use_only_the_libraries_design_allows(package: str) -> None:
    import sys

    stdlib = set(sys.stdlib_module_names)
    broken = []
    for path in modules_of(package):
        where = path.relative_to(ROOT).as_posix()
        for line, name in imported_modules(path):
            top = name.split(".")[0]
            if top in stdlib or top in PACKAGES or top in THIRD_PARTY[package]:
                continue
            broken.append(f"{where}:{line}: imports {name} (not in docs/architecture.md's table)")
    assert not broken, "\n".join(broken)


def test_core_uses_only_stdlib_msgspec_and_lark_and_no_clock_or_threads() -> None:
    import sys

    stdlib = set(sys.stdlib_module_names)
    broken = []
    for path in modules_of("pipeline"):
        for line, name in imported_modules(path):
            top = name.split(".")[0]
            if top in FORBIDDEN_IN_CORE:
                broken.append(
                    f"{path.relative_to(ROOT)}:{line}: {name} (clock/threads/global random)"
                )
            elif top not in stdlib and top not in THIRD_PARTY_IN_CORE and top != "pipeline":
                broken.append(f"{path.relative_to(ROOT)}:{line}: {name} (not allowed in the core)")
    assert not broken, "\n".join(broken)


@pytest.mark.parametrize("package", PACKAGES)
def test_the_folders_are_imported_only_through_the_one_import_name(package: str) -> None:
    """Installed, only ``oimi`` is a top-level name: ``import pipeline`` would work in the
    repository and fail for a user who installed the wheel."""
    broken = [
        f"{path.relative_to(ROOT)}:{line}: imports {name} (write oimi.{name})"
        for path in modules_of(package)
        for line, name in raw_imports(path)
        if name.split(".")[0] in FOLDERS
    ]
    assert not broken, "\n".join(broken)


def test_the_import_walker_sees_a_forbidden_import(tmp_path: Path) -> None:
    module = tmp_path / "bad.py"
    module.write_text("import time\nfrom oimi.recorder.mcap_sink import McapSink\n")
    assert imported_modules(module) == [(1, "time"), (2, "recorder.mcap_sink")]


STAGES = ("sense", "think", "act")
"""The loop's stages: they talk through ``pipeline.messages`` and ``pipeline.events``."""


@pytest.mark.parametrize("stage", STAGES)
def test_sense_think_and_act_never_import_each_other(stage: str) -> None:
    others = {f"pipeline.{s}" for s in (*STAGES, "operator") if s != stage}
    broken = [
        f"{path.relative_to(ROOT)}:{line}: imports {name}"
        for path in sorted((ROOT / "pipeline" / stage).rglob("*.py"))
        for line, name in imported_modules(path)
        if any(name == o or name.startswith(o + ".") for o in others)
    ]
    assert not broken, "\n".join(broken)


APPLICATIONS = ("oimi.live", "oimi.batch", "oimi.bench", "oimi.ros2")
"""The applications beside the command line (docs/architecture.md: they live under ``oimi/``)."""


@pytest.mark.parametrize("package", [p for p in FOLDERS if p != "pipeline"])
def test_the_folders_never_import_the_applications(package: str) -> None:
    broken = [
        f"{path.relative_to(ROOT)}:{line}: imports {name}"
        for path in modules_of(package)
        for line, name in raw_imports(path)
        if any(name == a or name.startswith(a + ".") for a in APPLICATIONS)
    ]
    assert not broken, "\n".join(broken)


def test_the_simulation_never_imports_the_session() -> None:
    """The world, humans and sensors are driven by a session; they never reach back into it."""
    broken = [
        f"{path.relative_to(ROOT)}:{line}: imports {name}"
        for path in sorted((ROOT / "scenarios" / "simulation").rglob("*.py"))
        for line, name in imported_modules(path)
        if name == "scenarios.session" or name.startswith("scenarios.session.")
    ]
    assert not broken, "\n".join(broken)


def test_the_applications_live_under_oimi() -> None:
    for app in ("live", "batch"):
        assert (ROOT / "oimi" / app / "__init__.py").is_file(), app
        assert not list((ROOT / "scenarios" / app).rglob("*.py")), app
