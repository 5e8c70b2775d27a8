"""``--extension MODULE`` on every command that compiles, checks, runs, serves, replays or
batches: the extensions named there, loaded with the installed ones."""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from pathlib import Path
from typing import Final

from oimi.scenarios.extensions import Toolkit, build_toolkit, load_extensions

EXTENDABLE: Final = ("compile", "check", "run", "serve", "replay", "batch")
"""The sub-commands that take ``--extension``."""


def add_extension_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--extension",
        action="append",
        default=[],
        metavar="MODULE",
        help="an extension to load: a module name, a .py file or a package folder (repeatable)",
    )


def extensions_of(args: argparse.Namespace) -> list[str]:
    """The ``--extension`` values (empty when the command has none); a path that exists is
    made absolute, so that batch workers find it whatever their folder."""
    return [
        str(Path(value).resolve()) if Path(value).exists() else value
        for value in getattr(args, "extension", None) or []
    ]


def toolkit_of(args: argparse.Namespace) -> Toolkit:
    """The built-ins plus the ``--extension`` and installed extensions."""
    return build_toolkit(load_extensions(extensions_of(args)))


EXTENSION_HINT: Final = (
    "hint: a function an extension adds is known only with that extension loaded:"
    " --extension MODULE (a module name, a .py file or a package folder; docs/extending.md)"
)


def extension_hint(args: argparse.Namespace, messages: Iterable[str]) -> str | None:
    """:data:`EXTENSION_HINT` when a script or condition calls an unknown function that is
    not a near miss of a known one (no "did you mean") and no
    ``--extension`` was given (None otherwise)."""
    unknown = ("unknown function " in m and "did you mean" not in m for m in messages)
    if extensions_of(args) or not any(unknown):
        return None
    return EXTENSION_HINT
