"""The Rerun viewer on a recording (``oimi view``): an MCAP is converted to Rerun first.

``save`` only writes the Rerun recording (no screen needed), checked first as ``oimi run``
checks its outputs: an ``.rrd`` name, never the recording being viewed (even with
``overwrite``), not an existing file unless ``overwrite``; it is written as
``NAME.partial.rrd`` and renamed once complete, so a failed save leaves nothing at the
target and no partial file. Otherwise the viewer
starts bound to 127.0.0.1 (Rerun's default is 0.0.0.0) with Rerun's analytics off;
``web`` serves the web viewer on 127.0.0.1 instead of opening a window, through
:mod:`oimi.web_viewer` so the page asks nothing of another machine. A damaged MCAP
(a killed run) is converted up to its damage, and how much was recovered is printed.
A viewer this machine cannot run as asked (no display for a window, a port in use, no
viewer binary) is ``ViewerError``: bad input (exit 2), saying what to do instead.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
from collections.abc import Mapping
from pathlib import Path
from typing import Final

from oimi.pipeline.errors import LocatedError
from oimi.recorder.errors import RecordingError
from oimi.recorder.outputs import (
    OutputError,
    check_outputs,
    check_replace,
    claim_partial,
    finish_partial,
)
from oimi.recorder.rerun_sink import mcap_to_rrd
from oimi.recorder.rrd import check_rrd
from oimi.web_viewer import PrivateViewer

EXIT_OK, EXIT_FAILED = 0, 1
BIND_ADDRESS: Final = "127.0.0.1"
"""Every server the viewer opens listens here only (Rerun's own default is 0.0.0.0)."""
DEFAULT_WEB_PORT: Final = 9090
DEFAULT_GRPC_PORT: Final = 9876
ANALYTICS_OFF_VARIABLE: Final = "CI"
"""Rerun 0.41's viewer records no analytics when ``CI`` is set (any value); it has no
other switch but ``rerun analytics disable``, which is persistent and left to the user."""
ANALYTICS_FORCE_VARIABLE: Final = "FORCE_RERUN_ANALYTICS"
"""Overrides the above in Rerun; removed from the viewer's environment."""
DEAD_PROXY: Final = "http://127.0.0.1:9"
"""Where the viewer's own HTTP requests (its update check) are sent: a loopback port
nothing serves, so they fail on this machine. Rerun's HTTP client honours the usual
proxy variables; loopback (its gRPC server, the recording) is exempt."""
PROXY_VARIABLES: Final = ("HTTPS_PROXY", "https_proxy", "HTTP_PROXY", "http_proxy", "ALL_PROXY")
NO_PROXY: Final = "127.0.0.1,localhost,::1"
SUFFIXES: Final = (".mcap", ".rrd")
RRD_SUFFIX: Final = ".rrd"


class ViewerError(LocatedError):
    """The viewer cannot run here as asked; the message says what to do instead."""


def view(
    source: Path,
    *,
    save: Path | None = None,
    overwrite: bool = False,
    port: int | None,
    web: bool,
    web_port: int,
) -> int:
    """Write ``source`` as Rerun's recording to ``save``, or show it in the viewer until it
    is closed: ``EXIT_OK``, or ``EXIT_FAILED`` when the viewer fails; a missing or
    unreadable recording, or a ``save`` refused by :func:`check_save`, raises
    ``RecordingError``, and a viewer that cannot run here (no display) ``ViewerError``,
    both before anything is converted."""
    _check_readable(source)
    if save is not None:
        check_save(source, save, overwrite=overwrite)
    if source.suffix.lower() == ".rrd":
        check_rrd(source)
    if save is not None:
        save_rrd(source, save, overwrite=overwrite)
        print(f"rerun: {save}")
        return EXIT_OK
    problem = display_problem(web=web, environ=os.environ, platform=sys.platform)
    if problem is not None:
        raise ViewerError(problem, source="oimi view")
    with tempfile.TemporaryDirectory(prefix="oimi-view-") as folder:
        rrd = source
        if source.suffix.lower() == ".mcap":
            rrd = Path(folder) / f"{source.stem}.rrd"
            write_rrd(source, rrd)
        return start_viewer(rrd, port=port, web=web, web_port=web_port)


def _check_readable(source: Path) -> None:
    """A clear ``RecordingError`` (exit 2) for a wrong suffix or a file that cannot be read."""
    if source.suffix.lower() not in SUFFIXES:
        raise RecordingError(
            f"expected an oimi recording (.mcap) or a Rerun recording (.rrd), not {source.name!r}",
            source=str(source),
        )
    try:
        with open(source, "rb"):
            pass
    except OSError as error:
        raise RecordingError(f"cannot read: {error.strerror}", source=str(source)) from None


def check_save(source: Path, target: Path, *, overwrite: bool) -> None:
    """Refuse (``OutputError``, exit 2) a ``--save`` target before anything is written: the
    recording being viewed (by any name, or as the partial file; even with ``overwrite``),
    a name not ending in ``.rrd``, and what :func:`~oimi.recorder.outputs.check_outputs`
    refuses of any recording."""
    check_replace(target, inputs=(source,), overwrite=True)  # said before its suffix
    if target.suffix.lower() != RRD_SUFFIX:
        given = f"not {target.suffix!r}" if target.suffix else "it has none"
        raise OutputError(
            f"a Rerun recording is saved with the {RRD_SUFFIX} suffix, {given} (for example"
            f" {target.stem}{RRD_SUFFIX})",
            source=str(target),
        )
    check_outputs((target,), overwrite=overwrite, inputs=(source,))


def save_rrd(source: Path, target: Path, *, overwrite: bool) -> None:
    """Write ``source`` as a Rerun recording to ``target``'s partial file (created
    exclusively), renamed to ``target`` once complete; a failed conversion removes the
    partial file and leaves ``target`` as it was. Without ``overwrite`` no file is replaced,
    even one that appeared meanwhile. ``target`` was checked by :func:`check_save`."""
    partial = claim_partial(target, overwrite=overwrite)
    try:
        write_rrd(source, partial)
    except BaseException:
        partial.unlink(missing_ok=True)
        raise
    finish_partial(partial, target, overwrite=overwrite)


def write_rrd(source: Path, target: Path) -> None:
    """``source`` as a Rerun recording at ``target``; a damaged MCAP's recovery is printed."""
    if source.suffix.lower() == ".rrd":
        if source.resolve() != target.resolve():
            shutil.copyfile(source, target)
        return
    recording = mcap_to_rrd(source, target)
    if recording.recovery is not None:
        print(f"{source}: {recording.recovery}; converted up to it", file=sys.stderr)


def display_problem(*, web: bool, environ: Mapping[str, str], platform: str) -> str | None:
    """Why a native viewer window cannot open here, or None."""
    if web or not platform.startswith("linux"):
        return None
    if environ.get("DISPLAY") or environ.get("WAYLAND_DISPLAY"):
        return None
    return (
        "no display ($DISPLAY and $WAYLAND_DISPLAY are not set): write the Rerun recording"
        f" with --save OUT.rrd, or serve the web viewer on {BIND_ADDRESS} with --web"
    )


def viewer_command(rrd: Path, *, port: int | None, web: bool, web_port: int) -> list[str]:
    """The command line that starts Rerun's viewer on ``rrd``, bound to 127.0.0.1.

    With ``web``, Rerun only serves (``--serve-web``: its viewer's files on ``web_port``
    and the recording over gRPC) and opens no browser on its own page."""
    command = [sys.executable, "-m", "rerun_cli", "--bind", BIND_ADDRESS]
    if port is not None:
        command += ["--port", str(port)]
    if web:
        command += ["--serve-web", "--web-viewer-port", str(web_port)]
    else:
        command += ["--hide-welcome-screen"]
    return [*command, str(rrd)]


def viewer_environment(environ: Mapping[str, str], *, web: bool = False) -> dict[str, str]:
    """The viewer's environment: ours, with Rerun's analytics off and its HTTP requests
    sent to :data:`DEAD_PROXY` (this process only). With ``web``, Rerun logs warnings only:
    its address of the unguarded page is not printed."""
    env = {k: v for k, v in environ.items() if k != ANALYTICS_FORCE_VARIABLE}
    env.setdefault(ANALYTICS_OFF_VARIABLE, "1")
    env.update(dict.fromkeys(PROXY_VARIABLES, DEAD_PROXY))
    env["NO_PROXY"] = env["no_proxy"] = NO_PROXY
    if web:
        env.setdefault("RUST_LOG", "warn")
    return env


def start_viewer(rrd: Path, *, port: int | None, web: bool, web_port: int) -> int:
    """Run the viewer on ``rrd`` until it is closed (or Ctrl-C): ``EXIT_FAILED`` when it
    exits with an error; ``ViewerError`` when it cannot start."""
    page = None
    if web:
        grpc = port or DEFAULT_GRPC_PORT
        _check_free(grpc, "--port")  # (taken, Rerun would only warn, and exit 0)
        assets = _free_port()
        try:
            page = PrivateViewer(web_port, assets_port=assets, grpc_port=grpc)
        except OSError as error:
            raise _cannot_listen(web_port, error, "--web-port") from None
        command = viewer_command(rrd, port=grpc, web=True, web_port=assets)
        page.start()
        print(f"web viewer: {page.url} (Ctrl-C to stop)")
    else:
        command = viewer_command(rrd, port=port, web=False, web_port=web_port)
        print(f"Rerun viewer on {rrd.name} (gRPC on {BIND_ADDRESS}:{port or DEFAULT_GRPC_PORT})")
    sys.stdout.flush()
    try:
        environment = viewer_environment(os.environ, web=web)
        status = run_viewer(command, environment)
    except OSError as error:
        raise ViewerError(
            f"cannot start the Rerun viewer: {error} (--save OUT.rrd writes the recording"
            " without one)",
            source="oimi view",
        ) from None
    finally:
        if page is not None:
            page.shutdown()
            page.server_close()
    if status != 0:
        print(f"oimi view: the Rerun viewer exited with status {status}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def run_viewer(command: list[str], environment: dict[str, str]) -> int:
    """Run the viewer until it exits; its status. Stopped (Ctrl-C, or SIGTERM), it is
    stopped too, with the processes it started (its own group: ``rerun_cli`` runs the
    viewer's binary as a child), never left running on its ports; then KeyboardInterrupt
    ("interrupted")."""
    child = subprocess.Popen(command, env=environment, process_group=0)
    main = threading.current_thread() is threading.main_thread()

    def terminated(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, terminated) if main else None
    try:
        return child.wait()
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        _stop_group(child)


def _stop_group(child: subprocess.Popen[bytes]) -> None:
    """SIGTERM to ``child``'s process group, SIGKILL to what is left of it after 10 s."""
    for stop in (signal.SIGTERM, signal.SIGKILL):
        with contextlib.suppress(ProcessLookupError):
            os.killpg(child.pid, stop)
        try:
            child.wait(timeout=10)
            return
        except subprocess.TimeoutExpired:
            continue


def _check_free(port: int, option: str) -> None:
    """``ViewerError`` naming ``option`` when something listens on ``port`` of
    :data:`BIND_ADDRESS` (probed as Rerun binds: with ``SO_REUSEADDR``)."""
    with socket.socket() as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind((BIND_ADDRESS, port))
        except OSError as error:
            raise _cannot_listen(port, error, option) from None


def _cannot_listen(port: int, error: OSError, option: str) -> ViewerError:
    return ViewerError(
        f"cannot listen on {BIND_ADDRESS}:{port}: {error.strerror} (choose another with {option})",
        source="oimi view",
    )


def _free_port() -> int:
    """A loopback port nobody listens on now (for Rerun's internal file server)."""
    with socket.socket() as probe:
        probe.bind((BIND_ADDRESS, 0))
        return probe.getsockname()[1]
