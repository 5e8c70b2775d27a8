"""Small modules: none over ~500 lines unless its docstring says why (``Long module:``)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FOLDERS = ("pipeline", "scenarios", "recorder", "replay", "analysis", "oimi", "tests", "examples")
MAX_LINES = 500
MARKER = "Long module:"


def too_long(path: Path, root: Path = ROOT) -> str | None:
    """Why ``path`` breaks the rule, or None when it keeps it."""
    text = path.read_text()
    lines = text.count("\n")
    if lines <= MAX_LINES:
        return None
    docstring = ast.get_docstring(ast.parse(text)) or ""
    reason = docstring.partition(MARKER)[2].strip()
    if reason:
        return None
    return f"{path.relative_to(root)}: {lines} lines and no '{MARKER} <why>' in its docstring"


def test_no_module_is_long_without_a_stated_reason() -> None:
    modules = sorted(p for folder in FOLDERS for p in (ROOT / folder).rglob("*.py"))
    assert len(modules) > 100
    broken = [problem for path in modules if (problem := too_long(path))]
    assert not broken, "\n".join(broken)


def test_a_long_module_needs_a_reason_and_a_short_one_does_not(tmp_path: Path) -> None:
    body = "x = 1\n" * (MAX_LINES + 1)
    silent = tmp_path / "silent.py"
    silent.write_text('"""A module."""\n' + body)
    stated = tmp_path / "stated.py"
    stated.write_text(f'"""A module.\n\n{MARKER} one table.\n"""\n' + body)
    empty = tmp_path / "empty.py"
    empty.write_text(f'"""A module.\n\n{MARKER}\n"""\n' + body)
    short = tmp_path / "short.py"
    short.write_text("x = 1\n")
    assert too_long(silent, tmp_path) and too_long(empty, tmp_path)
    assert too_long(stated, tmp_path) is None and too_long(short, tmp_path) is None
