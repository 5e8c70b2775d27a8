"""``--json``: one machine-readable summary on stdout; everything for people goes to stderr."""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Iterator
from typing import Any

import msgspec

_STREAM = "_json_stream"
_EMITTED = "_json_emitted"


def add_json_argument(parser: argparse.ArgumentParser) -> None:
    """``--json`` on a command that calls :func:`emit` once with its summary."""
    parser.add_argument(
        "--json",
        action="store_true",
        help="print one JSON summary on stdout; messages and progress go to stderr",
    )


def wanted(args: argparse.Namespace) -> bool:
    return bool(getattr(args, "json", False))


@contextlib.contextmanager
def human_to_stderr(args: argparse.Namespace) -> Iterator[None]:
    """With ``--json``, send what the command prints for people to stderr meanwhile,
    keeping stdout for :func:`emit`; otherwise nothing changes."""
    if not wanted(args):
        yield
        return
    setattr(args, _STREAM, sys.stdout)
    with contextlib.redirect_stdout(sys.stderr):
        yield


def emit(args: argparse.Namespace, summary: dict[str, Any]) -> None:
    """Print ``summary`` as one line of JSON on stdout, when ``--json`` was given."""
    if not wanted(args):
        return
    if getattr(args, _EMITTED, False):
        return
    setattr(args, _EMITTED, True)
    stream = getattr(args, _STREAM, sys.stdout)
    stream.write(msgspec.json.encode(summary).decode() + "\n")
    stream.flush()


def finish(args: argparse.Namespace, exit_code: int, error: str = "") -> None:
    """With ``--json``, make sure one summary was printed: a command that stopped early
    (bad input) gets ``{"command", "ok": false, "exit_code", "error"}``."""
    summary: dict[str, Any] = {"command": args.command, "ok": exit_code == 0}
    summary["exit_code"] = exit_code
    if error:
        summary["error"] = error
    emit(args, summary)


def result_summary(result: Any) -> dict[str, Any]:
    """A ``scenarios.session.runner.RunResult`` as JSON-ready data: the summary, each verdict,
    counts.
    ``expectations`` is ``"not applicable"`` for a live session (it has no verdicts)."""
    verdicts = [msgspec.to_builtins(v) for v in result.verdicts]
    passed = sum(v.ok for v in result.verdicts)
    return {
        "summary": msgspec.to_builtins(result.summary),
        "verdicts": verdicts,
        "passed": passed,
        "failed": len(verdicts) - passed,
    }
