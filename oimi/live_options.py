"""Options shared by ``oimi serve`` and ``oimi bridge``: the session's fields for its record,
and ``--foxglove [PORT]`` (also ``oimi replay``) for Foxglove's live connection."""

from __future__ import annotations

import argparse
import secrets
from datetime import UTC, datetime

from oimi.recorder.foxglove_live import DEFAULT_PORT, FoxgloveLiveSink
from oimi.scenarios.schema import Scenario
from oimi.scenarios.session.info import SessionInfo, new_session_info
from oimi.scenarios.session.recording import scene_of
from oimi.scenarios.session.runner import Session


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


def add_foxglove_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--foxglove",
        nargs="?",
        type=int,
        const=DEFAULT_PORT,
        metavar="PORT",
        help=f"serve the session to Foxglove over WebSocket on 127.0.0.1:PORT"
        f" ({DEFAULT_PORT} when no PORT is given; 0: any free port)",
    )


def foxglove_sinks(args: argparse.Namespace, session: Session) -> list[FoxgloveLiveSink]:
    """With ``--foxglove``: the live Foxglove server as a sink (its address printed)."""
    if args.foxglove is None:
        return []
    sink = FoxgloveLiveSink(port=args.foxglove, scene=scene_of(session.scenario))
    print(f"foxglove: {sink.url}  (Foxglove: Open connection > Foxglove WebSocket)", flush=True)
    return [sink]
