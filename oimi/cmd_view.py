"""View a recording in the Rerun viewer; an MCAP recording is converted to Rerun first.

``--save OUT.rrd`` only writes the Rerun recording (no screen needed). Like ``oimi run``'s
outputs, it is refused (exit 2, naming it) when it exists, unless ``--overwrite``, and
always when it is the recording being viewed; it must end in ``.rrd``; it is written as
``OUT.partial.rrd`` and renamed once complete. Otherwise the
viewer starts bound to 127.0.0.1 (Rerun's default is 0.0.0.0) with Rerun's analytics
off; ``--web`` serves the web viewer on 127.0.0.1 instead of opening a window, through
:mod:`oimi.web_viewer` so the page asks nothing of another machine. A
damaged MCAP (a killed run) is converted up to its damage, and how much was
recovered is printed. Exit 0 on success, 1 when the viewer exits with an error, 2 on a
missing or unreadable recording or a viewer that cannot run here as asked (no display
for a window, a ``--web-port`` in use), saying what to do instead.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from oimi.viewer import BIND_ADDRESS, DEFAULT_WEB_PORT, view


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "recording", type=Path, metavar="SESSION", help="an oimi recording (.mcap) or a .rrd"
    )
    parser.add_argument(
        "--save",
        type=Path,
        metavar="OUT.rrd",
        help="write the Rerun recording here and do not start the viewer",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="with --save: replace an existing OUT.rrd (default: refuse; never the input)",
    )
    parser.add_argument(
        "--port", type=_port, help="port of the viewer's gRPC server (default: Rerun's, 9876)"
    )
    parser.add_argument(
        "--web",
        action="store_true",
        help=f"serve the web viewer on {BIND_ADDRESS} instead of opening a window",
    )
    parser.add_argument(
        "--web-port",
        type=_port,
        default=DEFAULT_WEB_PORT,
        help=f"HTTP port of the web viewer (default {DEFAULT_WEB_PORT})",
    )


def _port(text: str) -> int:
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a port number: {text!r}") from None
    if not 1 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"port must be 1 to 65535, got {port}")
    return port


def run(args: argparse.Namespace) -> int:
    return view(
        args.recording,
        save=args.save,
        overwrite=args.overwrite,
        port=args.port,
        web=args.web,
        web_port=args.web_port,
    )
