"""``--extension MODULE`` on every command that compiles, checks, runs, serves, replays or
batches: the extensions named there, loaded with the installed ones."""

from __future__ import annotations

import argparse
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
