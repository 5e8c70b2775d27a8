"""The ``oimi`` command line: each sub-command parses, calls one library function, prints.

What ``--help`` says to users is in ``oimi/usage.py``, not in the modules' docstrings.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import sys
from collections.abc import Sequence

from oimi import jsonout, usage
from oimi.extension_args import EXTENDABLE, add_extension_argument
from oimi.pipeline.errors import LocatedError

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2

COMMANDS: tuple[str, ...] = (
    "compile",
    "check",
    "run",
    "demo",
    "replay",
    "view",
    "analyse",
    "serve",
    "batch",
    "bench",
    "bridge",
    "sim",
    "export",
    "info",
    "completion",
)
"""Sub-commands, each in ``oimi/cmd_<name>.py`` with ``add_arguments(parser)`` and ``run(args)``."""


def build_parser(names: Sequence[str] = COMMANDS) -> argparse.ArgumentParser:
    """The parser with the given sub-commands (importing only their modules)."""
    parser = argparse.ArgumentParser(
        prog="oimi",
        description=usage.DESCRIPTION,
        epilog=usage.EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"oimi {usage.version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in names:
        try:
            module = importlib.import_module(f"oimi.cmd_{name}")
        except ModuleNotFoundError as error:
            if error.name != f"oimi.cmd_{name}":
                raise
            continue
        command = sub.add_parser(
            name,
            help=usage.COMMANDS[name].summary,
            description=usage.description(name),
            epilog=usage.epilog(name),
            formatter_class=HelpFormatter,
        )
        module.add_arguments(command)
        if name in EXTENDABLE:
            add_extension_argument(command)
        command.set_defaults(handler=module.run)
    return parser


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Keeps the description's paragraphs and the examples' lines as written, and shows
    each option's default when its help does not already."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if "default" in text or action.default in (None, False, "", [], argparse.SUPPRESS):
            return text
        if action.option_strings and action.nargs != 0:
            return f"{text} (default: %(default)s)"
        return text


def main(argv: Sequence[str] | None = None) -> int:
    """Run one sub-command; its exit code. A reader that closes the pipe early
    (``oimi replay ... | head``) ends the command quietly, as the Python docs advise
    for SIGPIPE: the rest of the output goes to /dev/null."""
    try:
        code = _run(argv)
        sys.stdout.flush()
        return code
    except BrokenPipeError:
        with contextlib.suppress(OSError, ValueError):  # stdout is not a file (in a test)
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_FAILED


def _run(argv: Sequence[str] | None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    wanted = next((word for word in argv if not word.startswith("-")), None)
    args = build_parser([wanted] if wanted in COMMANDS else COMMANDS).parse_args(argv)
    try:
        with jsonout.human_to_stderr(args):
            code = int(args.handler(args) or EXIT_OK)
    except LocatedError as error:
        text = "\n".join(map(str, (error, *error.also)))
        print(text, file=sys.stderr)
        jsonout.finish(args, EXIT_BAD_INPUT, text)
        return EXIT_BAD_INPUT
    except BrokenPipeError:
        raise
    except OSError as error:
        if error.filename is None:
            raise
        print(f"{error.filename}: {error.strerror or error}", file=sys.stderr)  # unchecked path
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    jsonout.finish(args, code)
    return code
