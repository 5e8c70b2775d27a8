"""Check scripts (.txt DSL, .json), scenarios (.toml) and rule conditions without running them.

Prints ``FILE: ok`` for each good file and ``FILE:LINE:COL: message`` (to stderr) for each
problem; checks every file and exits 2 if any failed. A rule code that the rule library does
not know is a warning (the chain will refuse that message at run time), not a failure.
The checks are ``scenarios/checks.py``'s.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable

from oimi import jsonout
from oimi.extension_args import extension_hint, extensions_of
from oimi.pipeline.errors import LocatedError
from oimi.scenarios.checks import ConditionCheck, check

EXIT_OK, EXIT_BAD_INPUT = 0, 2


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "files", nargs="*", metavar="FILE", help="scripts (.txt, .json) or scenarios (.toml)"
    )
    parser.add_argument(
        "--condition",
        action="append",
        default=[],
        metavar="TEXT",
        help="a rule condition to check (repeatable)",
    )
    add_outside_paths_argument(parser)
    jsonout.add_json_argument(parser)


def add_outside_paths_argument(parser: argparse.ArgumentParser) -> None:
    """``--allow-outside-paths`` (check, run, serve, batch): scripts a scenario names may be
    outside its folder and the library."""
    parser.add_argument(
        "--allow-outside-paths",
        action="store_true",
        help="let a scenario's scripts be outside its folder and the library",
    )


def run(args: argparse.Namespace) -> int:
    if not args.files and not args.condition:
        report("nothing to check: give FILEs or --condition TEXT")
        return EXIT_BAD_INPUT
    failed = False
    checked: list[dict[str, object]] = []
    messages: list[str] = []  # of scripts and conditions: an extension's function, unknown?
    for item in check(
        args.files,
        args.condition,
        allow_outside=args.allow_outside_paths,
        extensions=extensions_of(args),
    ):
        if isinstance(item, ConditionCheck):
            errors = [item.error] if item.error else []
            checked.append(
                {
                    "condition": item.text,
                    "ok": not item.error,
                    "errors": errors,
                    "warnings": list(item.warnings),
                }
            )
            for warning in item.warnings:
                report(f"{warning} (warning)")
            if item.error:
                failed = True
                messages.append(item.error)
                report(item.error)
                report_context(item.context)
            else:
                print(f"<condition {item.number}>: ok")
            continue
        report_warnings(item.warnings)
        checked.append(
            {
                "file": item.file,
                "ok": not item.errors,
                "errors": [_error_json(e) for e in item.errors],
                "warnings": [_error_json(w) for w in item.warnings],
            }
        )
        if item.errors:
            failed = True
            for error in item.errors:
                report_error(error)
            if not item.file.endswith(".toml"):  # a scenario names its own extensions
                messages += [e.message for e in item.errors]
        else:
            print(f"{item.file}: ok")
    if hint := extension_hint(args, messages):
        report(hint)
    jsonout.emit(args, {"command": "check", "ok": not failed, "checked": checked})
    return EXIT_BAD_INPUT if failed else EXIT_OK


def _error_json(error: LocatedError) -> dict[str, object]:
    return {
        "source": error.source,
        "line": error.line,
        "column": error.column,
        "message": error.message,
        "text": str(error),
    }


def report(message: str) -> None:
    print(message, file=sys.stderr)


def report_warnings(warnings: Iterable[LocatedError]) -> None:
    """Each warning (``oimi check``, and a scenario's as ``oimi run`` or ``serve`` load it)."""
    for warning in warnings:
        report(f"{warning} (warning)")


def report_error(error: LocatedError) -> None:
    """``FILE:LINE:COL: message``, then the line and a caret when known."""
    report(str(error))
    report_context(getattr(error, "context", ""))


def report_context(context: str) -> None:
    """The offending line and its caret, indented under the message (nothing when unknown)."""
    if context:
        report("\n".join(f"    {line}" for line in context.splitlines()))
