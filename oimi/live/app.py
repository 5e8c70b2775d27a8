"""Serving a live session (``oimi serve``, ``oimi bridge``): check the arguments and outputs,
bind the ports, then run and record the session until Ctrl-C or ``--duration-s``.

The ports are bound and the outputs checked before the recording opens; it is written
as ``NAME.partial.mcap`` and renamed when the session ends. While it runs, the
addresses and the server's notes are printed; ``Served`` is what is left to report.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import datetime
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Final, NamedTuple

from oimi.cmd_check import report_warnings
from oimi.extension_args import extensions_of
from oimi.live.server import Addresses, LiveServer, ServeConfig, listen
from oimi.live.session import LiveSession
from oimi.live_options import foxglove_sinks, session_info
from oimi.pipeline.errors import LocatedError
from oimi.recorder.outputs import check_outputs
from oimi.scenarios.loader import LoadedScenario, load_scenario
from oimi.scenarios.session.info import SessionInfo
from oimi.scenarios.session.recording import dated_path, recorded
from oimi.scenarios.session.runner import RunResult

LIVE_CHUNK_BYTES: Final = 128 * 1024
"""A live session's MCAP chunks (uncompressed): a killed session loses at most the open
chunk, a few seconds of session rather than the default 1 MiB's minute or more."""


class Served(NamedTuple):
    """A live session that ended: what ``oimi serve`` reports."""

    ticks: int
    seconds: float
    info: SessionInfo
    result: RunResult
    output: Path


def live_session(seed: int | None) -> Callable[[LoadedScenario], Iterator[LiveSession]]:
    """``oimi serve``'s session maker: a plain live session of the scenario."""

    @contextlib.contextmanager
    def live(loaded: LoadedScenario) -> Iterator[LiveSession]:
        yield LiveSession(loaded, seed=seed)

    return live


def serve(
    args: argparse.Namespace,
    *,
    command: str,
    open_session: Callable[[LoadedScenario], contextlib.AbstractContextManager[LiveSession]],
    suffix: str = "",
    on_server: Callable[[LiveSession, LiveServer], None] | None = None,
    admit: Callable[[LoadedScenario], None] | None = None,
) -> Served:
    """Check the arguments (``oimi serve``'s) and outputs, bind the ports, then run and
    record a live session; bad input raises a ``LocatedError`` naming ``command``.

    ``open_session`` makes the session (``oimi serve``'s, or the ROS 2 bridge's);
    ``suffix`` goes after the scenario's name in the default recording name; ``admit``
    may refuse the loaded scenario (raising) before anything is opened.
    """
    if args.duration_s is not None and not args.duration_s > 0:  # NaN too
        raise LocatedError("--duration-s must be positive", source=command)
    if args.token is not None and not args.token:
        raise LocatedError("--token must not be empty", source=command)
    loaded = load_scenario(
        args.scenario, allow_outside=args.allow_outside_paths, extensions=extensions_of(args)
    )
    if admit is not None:
        admit(loaded)
    report_warnings(loaded.warnings)
    output = args.output or dated_path(
        Path("out"), f"{args.scenario.stem}{suffix}", ".mcap", now=datetime.datetime.now()
    )
    check_outputs((output, args.rrd), overwrite=args.overwrite)
    config = ServeConfig(
        host=args.host,
        tcp_port=None if args.no_tcp else args.port,
        http_port=None if args.no_console else args.http_port,
        token=args.token,
        allow_origins=tuple(args.allow_origin),
        duration_s=args.duration_s,
    )
    listeners = listen(config)  # ports first: a busy port opens no recording
    try:
        with open_session(loaded) as session:
            info = session_info(args, session.scenario)
            server = LiveServer(session, config, on_ready=announce, on_note=note, info=info)
            if on_server is not None:
                on_server(session, server)
            with recorded(
                session,
                mcap=output,
                rrd=args.rrd,
                overwrite=args.overwrite,
                chunk_size_bytes=LIVE_CHUNK_BYTES,
                world_every_n_ticks=args.world_every,
                info=info,
                final_info=lambda: server.info,
                sinks=foxglove_sinks(args, session),
            ):
                asyncio.run(server.run(listeners))
    finally:
        listeners.close()
    return Served(
        ticks=server.ticks,
        seconds=server.ticks * session.tick_ms / 1000,
        info=server.info or info,
        result=session.result(),
        output=output,
    )


def announce(addresses: Addresses) -> None:
    """Print where the App Interface and the console listen."""
    if addresses.tcp is not None:
        host, port = addresses.tcp
        print(f"app interface: tcp {host}:{port}")
    if addresses.console is not None:
        print(f"console: {addresses.console}")
    print("serving; Ctrl-C to stop", flush=True)


def note(text: str) -> None:
    """Print one of the server's notes (a refused input, a client gone) on stderr."""
    print(f"note: {text}", file=sys.stderr, flush=True)
