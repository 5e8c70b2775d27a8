"""`oimi view --web` in a subprocess, opened in headless Chromium (Debian's, driven by
Playwright) with every request logged and every request off this machine refused.

Also makes the screenshots of docs/recording.md:
``PYTHONPATH=$PWD python tests/cli/viewer_browser.py SESSION.mcap docs/ [FRACTION]``.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import urlparse

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = Path("/usr/bin/chromium")
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--enable-unsafe-swiftshader",
]
LOOPBACK = {"127.0.0.1", "localhost", "::1", "[::1]"}
ADDRESS = re.compile(r"^web viewer: (http://127\.0\.0\.1:\d+/\S*) \(Ctrl-C to stop\)$")
REFUSED = "oimi: no request leaves this machine ("


def missing() -> str | None:
    """Why the browser tests cannot run here, or None."""
    if not CHROMIUM.exists():
        return f"{CHROMIUM} is missing (apt-get install chromium)"
    try:
        import playwright.sync_api  # noqa: F401
    except ImportError:
        return "the playwright package is missing (pip install playwright)"
    return None


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def viewing(recording: Path) -> Iterator[tuple[str, int, int]]:
    """``oimi view RECORDING --web`` on free ports: (printed address, gRPC port, web port)."""
    grpc, web = free_port(), free_port()
    options = ["--web", "--port", str(grpc), "--web-port", str(web)]
    process = subprocess.Popen(
        [sys.executable, "-m", "oimi", "view", str(recording), *options],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        assert process.stdout is not None
        line = process.stdout.readline().rstrip("\n")  # printed before the viewer starts
        match = ADDRESS.match(line)
        assert match, (line, process.poll())
        yield match.group(1), grpc, web
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGINT)  # Ctrl-C: it stops the viewer it started
        try:
            process.communicate(timeout=15)
        except subprocess.TimeoutExpired:
            process.kill()
            process.communicate()


@dataclass
class Traffic:
    """Every request the page made, by URL, and what its console said."""

    requests: list[str] = field(default_factory=list)
    console: list[str] = field(default_factory=list)

    @property
    def external(self) -> list[str]:
        return [url for url in self.requests if not _local(url)]

    def refused(self, host: str) -> bool:
        return any(REFUSED + "https://" + host in text for text in self.console)


def _local(url: str) -> bool:
    parsed = urlparse(url)
    return parsed.scheme in ("data", "blob") or parsed.hostname in LOOPBACK


@contextlib.contextmanager
def browser(width: int, height: int) -> Iterator[tuple[object, Traffic]]:
    """A page in headless Chromium that logs every request and refuses those off loopback."""
    from playwright.sync_api import sync_playwright

    traffic = Traffic()

    def route(route) -> None:
        traffic.requests.append(route.request.url)
        if _local(route.request.url):
            route.continue_()
        else:
            route.abort()

    with tempfile.TemporaryDirectory() as profile, sync_playwright() as p:
        context = p.chromium.launch_persistent_context(
            profile,
            executable_path=str(CHROMIUM),
            args=FLAGS,
            headless=True,
            viewport={"width": width, "height": height},
        )
        context.route("**/*", route)
        context.on(
            "request", lambda r: traffic.requests.append(r.url) if not _local(r.url) else None
        )
        page = context.new_page()
        page.on("console", lambda message: traffic.console.append(message.text))
        page.on("websocket", lambda ws: traffic.requests.append(ws.url))
        try:
            yield page, traffic
        finally:
            context.close()


def wait_until(page, condition, *, seconds: float) -> bool:
    """Poll ``condition`` while the page runs, at most ``seconds``; its last value."""
    deadline = time.monotonic() + seconds
    while not condition():
        if time.monotonic() > deadline:
            return False
        page.wait_for_timeout(250)
    return True


def screenshots(recording: Path, folder: Path, at: float | None = None) -> list[Path]:
    """The default view of ``recording`` at 1280x800 and 1920x1080, once it has loaded;
    at its end, or at the fraction ``at`` of its time bar."""
    made = []
    with viewing(recording) as (url, _, _):
        for width, height in ((1280, 800), (1920, 1080)):
            with browser(width, height) as (page, traffic):
                page.goto(url)
                wait_until(
                    page, lambda: any("ReadMessages" in r for r in traffic.requests), seconds=90
                )
                page.wait_for_timeout(10_000)  # let the software renderer draw the recording
                if at is not None:  # pause (playback ran on), click the collapsed time bar
                    page.keyboard.press("Space")
                    left, right = 290, width - 205
                    page.mouse.click(left + at * (right - left), height - 14)
                page.wait_for_timeout(8_000)
                path = folder / f"rerun-view-{width}x{height}.png"
                page.screenshot(path=str(path))
                made.append(path)
    return made


if __name__ == "__main__":
    signal.signal(signal.SIGINT, signal.default_int_handler)
    at = float(sys.argv[3]) if len(sys.argv) > 3 else None
    for made in screenshots(Path(sys.argv[1]), Path(sys.argv[2]), at):
        print(made)
