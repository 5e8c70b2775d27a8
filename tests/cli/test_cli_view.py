"""`oimi view`: MCAP -> Rerun conversion, --save without a screen, a viewer bound to 127.0.0.1."""

from __future__ import annotations

import contextlib
import re
import signal
import socket
import struct
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import psutil
import pytest
from oimi.scenarios.loader import parse_scenario
from oimi.scenarios.session.recording import recorded
from oimi.scenarios.session.runner import Session
from rerun.chunk import RrdReader

from oimi import viewer as cmd_view
from oimi.cli import main

REPO = Path(__file__).resolve().parents[2]
SCENARIO = b"""\
name = "view"
seed = 2
duration_s = 1.0

[robot]
x_m = 3.0
y_m = 2.5

[[humans]]
id = "child"
x_m = 5.0
y_m = 2.6

[[activities]]
generator = "greeting"
"""


@pytest.fixture(scope="module")
def mcap(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("view")
    session = Session(parse_scenario(SCENARIO, source=folder / "view.toml"))
    path = folder / "view.mcap"
    with recorded(session, mcap=path, rrd=None):
        session.run()
    return path


def entities(rrd: Path) -> set[str]:
    return {c.entity_path for c in RrdReader(rrd).stream().to_chunks()}


def test_save_converts_an_mcap_to_rrd_with_the_recorded_id_and_entities(
    mcap: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out.rrd"
    assert main(["view", str(mcap), "--save", str(out)]) == 0
    assert capsys.readouterr().out == f"rerun: {out}\n"
    assert [r.recording_id for r in RrdReader(out).recordings()] == ["view-seed2"]
    assert {"/world/robot", "/world/humans/child", "/world/arena"} <= entities(out)


def test_save_of_an_rrd_copies_it(mcap: Path, tmp_path: Path) -> None:
    first = tmp_path / "first.rrd"
    assert main(["view", str(mcap), "--save", str(first)]) == 0
    second = tmp_path / "second.rrd"
    assert main(["view", str(first), "--save", str(second)]) == 0
    assert second.read_bytes() == first.read_bytes()


def test_a_truncated_mcap_converts_its_prefix_and_says_how_much_was_recovered(
    mcap: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = mcap.read_bytes()
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(data[: len(data) - 2000])  # the summary and the last chunk's end
    assert main(["view", str(damaged), "--save", str(tmp_path / "d.rrd")]) == 0
    err = capsys.readouterr().err
    assert err.startswith(f"{damaged}: damaged at byte ")
    assert "(the file ends inside a " in err
    assert "messages before it; converted up to it" in err
    assert "/world/robot" in entities(tmp_path / "d.rrd")


def _message_header_near(data: bytes, target: int) -> int:
    """The offset of the first message header at or after ``target`` in an ``.rrd``: a
    12-byte file header, then messages of a 16-byte header (kind, length: u64 LE) and
    ``length`` bytes. (A flip inside a message's Arrow data is not detectable: no checksum.)"""
    offset = 12
    while offset < target:
        offset += 16 + struct.unpack_from("<QQ", data, offset)[1]
    return offset


@pytest.mark.parametrize("cut", ["garbage", "truncated", "flipped"])
def test_a_bad_rrd_is_refused_with_exit_2_and_nothing_is_copied(
    mcap: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], cut: str
) -> None:
    good = tmp_path / "good.rrd"
    assert main(["view", str(mcap), "--save", str(good)]) == 0
    data = bytearray(good.read_bytes())
    if cut == "garbage":
        data = bytearray(b"not a Rerun recording at all" * 10)
    elif cut == "truncated":
        data = data[: len(data) // 2]
    else:  # a message's length, a third of the way in, flipped to all ones
        offset = _message_header_near(bytes(data), len(data) // 3)
        data[offset + 8 : offset + 16] = b"\xff" * 8
    bad = tmp_path / "bad.rrd"
    bad.write_bytes(bytes(data))
    capsys.readouterr()
    assert main(["view", str(bad), "--save", str(tmp_path / "copy.rrd")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{bad}: damaged or not a Rerun recording ("), err
    assert not (tmp_path / "copy.rrd").exists()


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("missing.mcap", None, r"missing\.mcap: cannot read: No such file or directory"),
        ("notes.toml", b"x", r"notes\.toml: expected an oimi recording \(\.mcap\) or a Rerun"),
        ("garbage.mcap", b"not an mcap file at all", r"garbage\.mcap: not an MCAP file"),
        ("empty.mcap", b"", r"empty\.mcap: empty file, not an MCAP recording"),
    ],
)
def test_bad_recordings_are_refused_with_exit_2_naming_the_file(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    name: str,
    content: bytes | None,
    message: str,
) -> None:
    path = tmp_path / name
    if content is not None:
        path.write_bytes(content)
    assert main(["view", str(path), "--save", str(tmp_path / "x.rrd")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(str(path))
    assert re.search(message, err), err


def test_without_a_display_it_is_bad_input_and_suggests_save_or_the_web_viewer(
    mcap: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Exit 2, as for any command this machine cannot do as given (1 is a failed check)."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(sys, "platform", "linux")
    assert main(["view", str(mcap)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("oimi view: no display")
    assert "--save OUT.rrd" in err and "127.0.0.1 with --web" in err


@pytest.mark.parametrize("option", ["--web-port", "--port"])
def test_a_port_in_use_is_bad_input_naming_the_option(
    option: str, mcap: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The page's port (``--web-port``) or Rerun's gRPC one (``--port``: taken, Rerun warns
    and exits 0, and the page would show nothing, or the session another viewer serves)."""
    monkeypatch.setattr(cmd_view, "run_viewer", lambda command, env: pytest.fail("started"))
    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
        assert main(["view", str(mcap), "--web", option, str(port)]) == 2
    err = capsys.readouterr().err
    assert f"oimi view: cannot listen on 127.0.0.1:{port}" in err and f"with {option})" in err


def test_display_problem_only_for_a_native_window_on_linux_without_display() -> None:
    problem = cmd_view.display_problem
    assert problem(web=False, environ={}, platform="linux") is not None
    assert problem(web=False, environ={"DISPLAY": ":0"}, platform="linux") is None
    assert problem(web=False, environ={"WAYLAND_DISPLAY": "w"}, platform="linux") is None
    assert problem(web=True, environ={}, platform="linux") is None
    assert problem(web=False, environ={}, platform="darwin") is None


def test_the_viewer_is_bound_to_localhost_with_analytics_off(tmp_path: Path) -> None:
    command = cmd_view.viewer_command(tmp_path / "a.rrd", port=9999, web=True, web_port=9091)
    assert command[command.index("--bind") + 1] == "127.0.0.1"
    assert command[command.index("--port") + 1] == "9999"
    assert command[command.index("--web-viewer-port") + 1] == "9091"
    assert "--serve-web" in command and "--web-viewer" not in command  # no browser on Rerun's page
    assert command[-1] == str(tmp_path / "a.rrd")
    env = cmd_view.viewer_environment(
        {"PATH": "/bin", "FORCE_RERUN_ANALYTICS": "1", "HTTPS_PROXY": "http://proxy.lan:3128"}
    )
    assert env["CI"] == "1" and "FORCE_RERUN_ANALYTICS" not in env
    assert cmd_view.viewer_environment({"CI": "true"})["CI"] == "true"


def test_the_viewers_own_http_requests_go_to_a_dead_loopback_port() -> None:
    env = cmd_view.viewer_environment({"HTTPS_PROXY": "http://proxy.lan:3128"})
    for name in ("HTTPS_PROXY", "https_proxy", "HTTP_PROXY", "http_proxy", "ALL_PROXY"):
        assert env[name] == "http://127.0.0.1:9", name
    assert env["NO_PROXY"] == env["no_proxy"] == "127.0.0.1,localhost,::1"
    assert "RUST_LOG" not in env
    assert cmd_view.viewer_environment({}, web=True)["RUST_LOG"] == "warn"


def test_with_a_display_the_converted_recording_goes_to_the_viewer_then_is_removed(
    mcap: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    seen: list[tuple[list[str], dict[str, str], set[str]]] = []

    def fake_run(command: list[str], env: dict[str, str]) -> int:
        seen.append((command, env, entities(Path(command[-1]))))
        return 0

    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setattr(cmd_view, "run_viewer", fake_run)
    assert main(["view", str(mcap), "--port", "9877"]) == 0
    [(command, env, shown)] = seen
    assert command[command.index("--bind") + 1] == "127.0.0.1"
    assert env["CI"], "CI set (to any value) turns Rerun's analytics off"
    assert "/world/robot" in shown
    assert not Path(command[-1]).exists()


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def listening(process: psutil.Process) -> list[tuple[int, str, int]]:
    found = []
    for p in [process, *process.children(recursive=True)]:
        try:
            found += [
                (p.pid, c.laddr.ip, c.laddr.port)
                for c in p.net_connections(kind="inet")
                if c.status == psutil.CONN_LISTEN
            ]
        except psutil.NoSuchProcess:
            continue
    return found


@contextlib.contextmanager
def web_viewer(mcap: Path) -> Iterator[tuple[subprocess.Popen[bytes], int, int, list]]:
    """``oimi view MCAP --web`` on free ports, once both listen: the process, the gRPC and
    web ports and the listening sockets (pid, address, port); stopped on leaving."""
    grpc, web = free_port(), free_port()
    options = ["--web", "--port", str(grpc), "--web-port", str(web)]
    process = subprocess.Popen(
        [sys.executable, "-m", "oimi", "view", str(mcap), *options],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    parent = psutil.Process(process.pid)
    try:
        deadline = time.monotonic() + 30
        sockets: list[tuple[int, str, int]] = []
        while time.monotonic() < deadline and {grpc, web} - {port for _, _, port in sockets}:
            assert process.poll() is None, process.communicate()
            time.sleep(0.2)
            sockets = listening(parent)
        assert {port for _, _, port in sockets} >= {grpc, web}, sockets
        yield process, grpc, web, sockets
    finally:
        if process.poll() is None:
            stop(parent, process)


def test_the_real_web_viewer_listens_on_127_0_0_1_only_with_analytics_off(mcap: Path) -> None:
    with web_viewer(mcap) as (_, grpc, _, sockets):
        assert {ip for _, ip, _ in sockets} == {"127.0.0.1"}
        [viewer] = {pid for pid, _, port in sockets if port == grpc}
        assert psutil.Process(viewer).environ().get("CI"), "analytics off in the viewer"


def test_a_web_viewer_stopped_with_sigterm_stops_its_rerun_viewer(mcap: Path) -> None:
    """SIGTERM (a service manager, `kill`) to `oimi view` alone: the Rerun viewer it started
    is stopped too (it was left running, on its ports, using a core)."""
    with web_viewer(mcap) as (process, _, _, _):
        children = psutil.Process(process.pid).children(recursive=True)
        assert children, "the viewer runs"
        process.send_signal(signal.SIGTERM)
        _, alive = psutil.wait_procs(children, timeout=15)
        assert alive == []
        _, err = process.communicate(timeout=15)
        assert process.returncode == 130 and b"interrupted" in err


def stop(parent: psutil.Process, process: subprocess.Popen[bytes]) -> None:
    """Ctrl-C to `oimi view` and the viewer it started; kill what is left after 10 s."""
    children = parent.children(recursive=True)
    for p in [*children, parent]:
        with contextlib.suppress(psutil.NoSuchProcess):
            p.send_signal(signal.SIGINT)
    _, alive = psutil.wait_procs(children, timeout=10)
    for p in alive:
        p.kill()
    try:
        process.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        process.kill()
        process.communicate()
