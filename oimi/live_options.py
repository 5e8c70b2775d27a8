"""Options shared by ``oimi serve`` and ``oimi bridge``: the session's fields for its record."""

from __future__ import annotations

import argparse
import secrets
from datetime import UTC, datetime

from scenarios.schema import Scenario
from scenarios.session_info import SessionInfo, new_session_info


def add_session_arguments(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("session record (written to the recording's metadata)")
    group.add_argument("--child", default="", metavar="PSEUDONYM", help="the child's pseudonym")
    group.add_argument("--therapist", default="", metavar="NAME", help="the therapist")
    group.add_argument("--notes", default="", metavar="TEXT", help="free notes on the session")


def session_info(args: argparse.Namespace, scenario: Scenario) -> SessionInfo:
    """The session's fields from the flags, dated now, with a unique recording id."""
    return new_session_info(
        scenario.name,
        started=datetime.now(UTC),
        suffix=secrets.token_hex(3),
        child=args.child,
        therapist=args.therapist,
        notes=args.notes,
    )


def print_session(info: SessionInfo) -> None:
    """The session's id and fields, as ``oimi serve`` prints them when it stops."""
    print(f"session {info.recording_id} on {info.date}")
    for name in ("child", "therapist", "notes"):
        value = getattr(info, name)
        if value:
            print(f"  {name}: {value}")

