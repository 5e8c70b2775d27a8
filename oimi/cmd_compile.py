"""Compile a script (the DSL of thesis section 4.4) to the thesis's Script JSON.

Writes the JSON to stdout, or atomically to ``-o OUT.json`` (nothing is written on error).
Like every command's output file, ``OUT.json`` is refused (exit 2, naming it) when it exists,
unless ``--overwrite``, and always when it is the script being compiled.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from functools import partial
from pathlib import Path

from oimi.cmd_check import report, report_error
from oimi.extension_args import extension_hint, toolkit_of
from oimi.pipeline.script import ScriptError, condition_errors, dump_script_json, parse_script
from oimi.pipeline.think.conditions import compile_condition
from oimi.recorder.outputs import check_output, check_replace, output_error

EXIT_OK, EXIT_BAD_INPUT = 0, 2


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("script", metavar="SCRIPT", help="a DSL script (.txt) or a Script JSON")
    parser.add_argument(
        "-o", "--output", metavar="OUT", help="JSON file to write (default: stdout)"
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="replace an existing OUT (default: refuse; never the SCRIPT itself)",
    )


def run(args: argparse.Namespace) -> int:
    source = Path(args.script)
    if args.output is not None:
        check_output(args.output, beside=True)  # written beside it, renamed into place
        check_replace(args.output, inputs=(source,), overwrite=args.overwrite)
    try:
        data = source.read_bytes()
    except OSError as error:
        report(f"{source}: cannot read the file: {error.strerror}")
        return EXIT_BAD_INPUT
    try:
        parsed = parse_script(data, source=str(source))
    except ScriptError as error:
        report_error(error)
        return EXIT_BAD_INPUT
    functions = toolkit_of(args).registries.functions
    errors = condition_errors(parsed, partial(compile_condition, registry=functions))
    for error in errors:
        report_error(error)
    if errors:
        if hint := extension_hint(args, (e.message for e in errors)):
            report(hint)
        return EXIT_BAD_INPUT
    text = dump_script_json(parsed.script)
    if args.output is None:
        sys.stdout.write(text)
        return EXIT_OK
    try:
        write_atomically(Path(args.output), text)
    except OSError as error:
        report(str(output_error(args.output, error)))
        return EXIT_BAD_INPUT
    return EXIT_OK


def write_atomically(path: Path, text: str) -> None:
    """Write ``text`` to a temporary file beside ``path`` (its missing folders made), then
    rename it over ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    umask = os.umask(0)
    os.umask(umask)
    try:
        os.chmod(temporary, 0o666 & ~umask)  # mkstemp makes 0600; give the usual mode
        with os.fdopen(handle, "w", encoding="utf-8", newline="\n") as stream:
            stream.write(text)
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise
