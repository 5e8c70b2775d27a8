"""Check scripts (.txt DSL, .json), scenarios (.toml) and rule conditions without running them.

Prints ``FILE: ok`` for each good file and ``FILE:LINE:COL: message`` (to stderr) for each
problem; checks every file and exits 2 if any failed. A rule code that the rule library does
not know is a warning (the chain will refuse that message at run time), not a failure.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from oimi import jsonout
from oimi.extension_args import extensions_of
from oimi.pipeline.errors import LocatedError
from oimi.pipeline.script import ParsedScript, ScriptError
from oimi.pipeline.think.conditions import compile_condition
from oimi.pipeline.think.functions import FunctionRegistry
from oimi.pipeline.think.rules import RuleRegistry
from oimi.scenarios.extensions import Toolkit, build_toolkit, load_extensions
from oimi.scenarios.loader import load_scenario
from oimi.scenarios.session.activities import check_script_file

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
    extensions = extensions_of(args)
    toolkit = build_toolkit(load_extensions(extensions))
    checked: list[dict[str, object]] = []
    for name in args.files:
        errors = check_file(
            Path(name),
            allow_outside=args.allow_outside_paths,
            extensions=extensions,
            toolkit=toolkit,
        )
        checked.append({"file": name, "ok": not errors, "errors": [_error_json(e) for e in errors]})
        if errors:
            failed = True
            for error in errors:
                report_error(error)
        else:
            print(f"{name}: ok")
    for number, text in enumerate(args.condition, start=1):
        message = check_condition(text, number, toolkit.registries.functions)
        errors = [message] if message else []
        checked.append({"condition": text, "ok": not message, "errors": errors})
        if message:
            failed = True
            report(message)
        else:
            print(f"<condition {number}>: ok")
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


def check_file(
    path: Path,
    *,
    allow_outside: bool = False,
    extensions: Sequence[str] = (),
    toolkit: Toolkit | None = None,
) -> list[LocatedError]:
    """Every problem found in one file (empty when it is fine), with these extensions."""
    if path.suffix.lower() == ".toml":
        return check_scenario(path, allow_outside=allow_outside, extensions=extensions)
    toolkit = toolkit or build_toolkit(load_extensions(extensions))
    parsed, errors = check_script_file(path, functions=toolkit.registries.functions)
    if parsed is not None:
        for warning in unknown_rule_codes(parsed, toolkit.registries.rules):
            report(f"{warning} (warning)")
    return errors


def unknown_rule_codes(parsed: ParsedScript, rules: RuleRegistry) -> list[ScriptError]:
    """Alfa/omega messages naming a rule code the rule library does not have."""
    script = parsed.script
    return [
        parsed.sourcemap.place(
            ScriptError(
                f"rule code {message.rulecode} ({message.id}) is not in the rule library",
                path=f"{kind}[{index}].rulecode",
            )
        )
        for kind, messages in (
            ("alfarulemessages", script.alfarulemessages),
            ("omegarulemessages", script.omegarulemessages),
        )
        for index, message in enumerate(messages)
        if message.rulecode not in rules
    ]


def check_scenario(
    path: Path, *, allow_outside: bool = False, extensions: Sequence[str] = ()
) -> list[LocatedError]:
    """A scenario's problems: everything ``oimi run`` would refuse, ranges, the robot's
    ceiling, its scripts and generators (``scenarios.loader.load_scenario`` checks it all)."""
    try:
        load_scenario(path, allow_outside=allow_outside, extensions=extensions)
    except LocatedError as error:
        return [error]
    except OSError as error:
        return [LocatedError(f"cannot read the file: {error.strerror}", source=str(path))]
    return []


def check_condition(text: str, number: int, functions: FunctionRegistry | None = None) -> str:
    """``""`` when ``text`` compiles, else ``<condition N>:COL: message``."""
    try:
        compile_condition(text, registry=functions)
    except LocatedError as error:
        return f"<condition {number}>:{error.column}: {error.message}"
    return ""


def report(message: str) -> None:
    print(message, file=sys.stderr)


def report_error(error: LocatedError) -> None:
    """``FILE:LINE:COL: message``, then the line and a caret when known."""
    report(str(error))
    context = getattr(error, "context", "")
    if context:
        report("\n".join(f"    {line}" for line in context.splitlines()))
