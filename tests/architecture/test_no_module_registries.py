"""No process-wide registry: registries are built per session and handed down
(docs/architecture.md).

Walks every module of the installed packages and fails on a module-level registry
instance (``RULES = RuleRegistry()``, a catalogue or a mutable dict/list named like a
registry) and on registering decorators (``@RULES.register``).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("pipeline", "scenarios", "recorder", "replay", "analysis", "oimi", "examples")
REGISTRY_TYPES = re.compile(r"(Registry|Registries|Catalogue|Toolkit|Extension)$")
REGISTRY_NAMES = re.compile(r"(REGISTRY|REGISTRIES|RULES|FUNCTIONS|GENERATORS|BEHAVIOURS)$")
MUTABLE_CALLS = {"dict", "list", "set", "defaultdict", "OrderedDict"}


def _callee(node: ast.expr) -> str:
    if isinstance(node, ast.Call):
        func = node.func
        return func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
    return ""


def _targets(node: ast.stmt) -> list[str]:
    if isinstance(node, ast.Assign):
        return [t.id for t in node.targets if isinstance(t, ast.Name)]
    if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
        return [node.target.id]
    return []


def registry_problems(source: str) -> list[str]:
    """Module-level registries and register decorators in one module's source."""
    tree = ast.parse(source)
    problems = []
    for node in tree.body:
        value = getattr(node, "value", None)
        for name in _targets(node):
            callee = _callee(value) if value is not None else ""
            if REGISTRY_TYPES.search(callee):
                problems.append(f"line {node.lineno}: {name} = {callee}(...) at module level")
            mutable = isinstance(value, ast.Dict | ast.List | ast.Set) or callee in MUTABLE_CALLS
            if REGISTRY_NAMES.search(name) and mutable:
                problems.append(f"line {node.lineno}: {name} is a mutable registry")
    for node in ast.walk(tree):
        for decorator in getattr(node, "decorator_list", []):
            target = decorator.func if isinstance(decorator, ast.Call) else decorator
            if isinstance(target, ast.Attribute) and target.attr == "register":
                problems.append(f"line {decorator.lineno}: @{ast.unparse(target)} registers")
    return problems


def test_the_scan_finds_the_old_pattern() -> None:
    old = "RULES = RuleRegistry()\n@RULES.register\nclass KickStarter(Rule): ...\n"
    assert len(registry_problems(old)) == 2
    assert registry_problems("HANDLERS: dict = {}\nGENERATORS = {}\n") == [
        "line 2: GENERATORS is a mutable registry"
    ]
    assert registry_problems("BUILTIN_RULES = (A, B)\ndef f():\n    r = RuleRegistry([])\n") == []


@pytest.mark.parametrize("package", PACKAGES)
def test_no_module_level_registry(package: str) -> None:
    files = sorted((ROOT / package).rglob("*.py"))
    assert files, package
    problems = [
        f"{path.relative_to(ROOT)} {problem}"
        for path in files
        for problem in registry_problems(path.read_text())
    ]
    assert problems == []
