"""Every file a Markdown doc points to exists and is tracked by git."""

from __future__ import annotations

import importlib
import posixpath
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

LINK = re.compile(r"\]\(([^)\s]+)\)")
"""A Markdown link's target: ``[text](target)``."""
MODULE = re.compile(r"`((?:[\w.-]+/)+[\w.-]+\.py)`")
"""A code span naming a Python file by its path (``pipeline/think/rulecodes.py``); only
paths under a folder of the repository count (``rules/library.py`` names an attachment)."""


def tracked() -> set[str]:
    out = subprocess.run(
        ["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout
    return set(out.splitlines())


TRACKED = tracked()
FOLDERS = {p.split("/")[0] for p in TRACKED if "/" in p}
DOCS = sorted(p for p in TRACKED if p.endswith(".md"))


def targets(doc: str) -> list[str]:
    """The repository paths ``doc`` points to (relative links, and module paths in code)."""
    text = (ROOT / doc).read_text(encoding="utf-8")
    found = []
    for target in LINK.findall(text):
        if re.match(r"[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
            continue  # a URL or an anchor in the same page
        path = target.split("#")[0]
        found.append(posixpath.normpath(posixpath.join(posixpath.dirname(doc), path)))
    found += [m for m in MODULE.findall(text) if m.split("/")[0] in FOLDERS]
    return found


def test_the_docs_are_found_and_point_somewhere() -> None:
    assert {"README.md", "docs/operator.md", "tests/golden/README.md"} <= set(DOCS)
    assert sum(len(targets(doc)) for doc in DOCS) >= 20


@pytest.mark.parametrize("doc", DOCS)
def test_every_file_a_doc_points_to_exists_and_is_tracked(doc: str) -> None:
    missing = [
        t
        for t in targets(doc)
        if t not in TRACKED and not any(p.startswith(t + "/") for p in TRACKED)
    ]
    assert missing == [], f"{doc} points to files that are not tracked: {missing}"


DOTTED = re.compile(r"`((?:pipeline|scenarios|recorder|replay|analysis|oimi)(?:\.\w+)+)`")
"""A code span naming a module or one of its names (``pipeline.think.stdlib``)."""
FILE_EXTENSIONS = {
    "csv",
    "json",
    "jsonl",
    "md",
    "mcap",
    "parquet",
    "py",
    "rrd",
    "toml",
    "txt",
    "xml",
}


def resolves(dotted: str) -> bool:
    """Whether ``dotted`` is a module, or a module's attribute chain."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            found: object = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for name in parts[cut:]:
            if not hasattr(found, name):
                return False
            found = getattr(found, name)
        return True
    return False


@pytest.mark.parametrize("doc", DOCS)
def test_every_module_a_doc_names_exists(doc: str) -> None:
    names = [
        n
        for n in DOTTED.findall((ROOT / doc).read_text(encoding="utf-8"))
        if n.rpartition(".")[2] not in FILE_EXTENSIONS  # replay.csv is a file, not a module
    ]
    assert [n for n in names if not resolves(n)] == [], f"{doc} names what does not exist"


def test_scenario_library_md_has_one_row_per_scenario_in_the_scenarios_table() -> None:
    """Each library scenario is a row of the scenarios table, and only there."""
    text = (ROOT / "docs" / "scenario-library.md").read_text(encoding="utf-8")
    scenarios_part, _, activities_part = text.partition("## Activities written for the library")
    rows = re.findall(r"^\| `(\w+)` \|", scenarios_part, flags=re.M)
    library = sorted(p.stem for p in (ROOT / "scenarios" / "library").glob("*.toml"))
    assert sorted(rows) == library
    listed = re.findall(r"^\| `([\w.]+)` \|", activities_part, flags=re.M)
    assert all(name.endswith(".txt") for name in listed), listed
