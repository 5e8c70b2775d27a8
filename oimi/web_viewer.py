"""Rerun's web viewer, served so that the browser asks nothing of any other machine.

Rerun (``--serve-web`` on 127.0.0.1) hosts the viewer's files and the recording (gRPC).
The page the browser opens comes from :class:`PrivateViewer`, also on 127.0.0.1: Rerun's
``index.html`` without its links to remote fonts, with :data:`GUARD` run before the
viewer (it refuses every ``fetch``, XHR, WebSocket and beacon to a host other than
this machine, which is how the viewer's analytics, update check and examples
manifest would leave), under a Content-Security-Policy that allows this machine
only; the viewer's script and wasm are forwarded from Rerun unchanged. ``/`` redirects
to the address that opens the recording.
"""

from __future__ import annotations

import re
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Final

LOOPBACK: Final = "127.0.0.1"
START_S: Final = 30.0
"""How long a request waits for Rerun's server to start listening."""
FORWARDED: Final = ("/re_viewer.js", "/re_viewer_bg.wasm", "/favicon.svg", "/favicon.ico")
"""The viewer's own files, forwarded from Rerun's loopback server."""

GUARD: Final = """<script>
/* oimi: this page may only talk to this machine (see docs/security.md#viewer-privacy). */
(() => {
  const local = (url) => {
    try {
      const host = new URL(url, location.href).hostname;
      return host === location.hostname || ["127.0.0.1", "localhost", "[::1]"].includes(host);
    } catch (error) {
      return false;
    }
  };
  const refuse = (url) => new TypeError(`oimi: no request leaves this machine (${url})`);
  const fetch0 = window.fetch.bind(window);
  window.fetch = (input, init) => {
    const url = input instanceof Request ? input.url : String(input);
    return local(url) ? fetch0(input, init) : Promise.reject(refuse(url));
  };
  const open0 = XMLHttpRequest.prototype.open;
  XMLHttpRequest.prototype.open = function (method, url, ...rest) {
    if (!local(url)) throw refuse(url);
    return open0.call(this, method, url, ...rest);
  };
  const Socket0 = window.WebSocket;
  window.WebSocket = function (url, protocols) {
    if (!local(url)) throw refuse(url);
    return new Socket0(url, protocols);
  };
  navigator.sendBeacon = (url) => local(url) && false;
})();
</script>"""


def content_security_policy(grpc_port: int) -> str:
    """Scripts, styles, fonts and connections from this page and Rerun's gRPC port only."""
    grpc = f"http://{LOOPBACK}:{grpc_port}"
    return "; ".join(
        [
            "default-src 'self'",
            "script-src 'self' 'unsafe-inline' 'wasm-unsafe-eval'",
            "style-src 'self' 'unsafe-inline'",
            "img-src 'self' data: blob:",
            "font-src 'self' data:",
            f"connect-src 'self' {grpc} http://localhost:{grpc_port} blob: data:",
            "worker-src 'self' blob:",
        ]
    )


_REMOTE_LINK: Final = re.compile(r"<link\b[^>]*\bhref=\"https?://[^>]*>\s*", re.IGNORECASE)


def private_page(html: str) -> str:
    """Rerun's ``index.html`` without remote links, with :data:`GUARD` first in ``<head>``."""
    html = _REMOTE_LINK.sub("", html)
    head = html.lower().find("<head>")
    if head < 0:
        return GUARD + html
    at = head + len("<head>")
    return html[:at] + "\n" + GUARD + html[at:]


def viewer_url(web_port: int, grpc_port: int) -> str:
    """The address that opens the recording served on ``grpc_port``."""
    source = urllib.parse.quote(f"rerun+http://{LOOPBACK}:{grpc_port}/proxy", safe="")
    return f"http://{LOOPBACK}:{web_port}/?url={source}&hide_welcome_screen"


class PrivateViewer(ThreadingHTTPServer):
    """The page and files of Rerun's web viewer on ``127.0.0.1:web_port`` (0: any free port);
    Rerun's own HTTP server is on ``assets_port``, its gRPC server on ``grpc_port``."""

    daemon_threads = True

    def __init__(self, web_port: int, *, assets_port: int, grpc_port: int) -> None:
        super().__init__((LOOPBACK, web_port), _Handler)
        self.assets = f"http://{LOOPBACK}:{assets_port}"
        self.grpc_port = grpc_port
        self.cache: dict[str, bytes] = {}
        self.lock = threading.Lock()

    @property
    def url(self) -> str:
        return viewer_url(self.server_address[1], self.grpc_port)

    def asset(self, path: str) -> bytes:
        """A file of Rerun's server (the page patched), fetched once from loopback."""
        with self.lock:
            if path not in self.cache:
                body = self._fetch(path)
                if path == "/index.html":
                    body = private_page(body.decode("utf-8")).encode("utf-8")
                self.cache[path] = body
            return self.cache[path]

    def _fetch(self, path: str) -> bytes:
        """``path`` from Rerun's server, waiting up to :data:`START_S` for it to listen."""
        deadline = time.monotonic() + START_S
        while True:
            try:
                with urllib.request.urlopen(self.assets + path, timeout=START_S) as response:
                    return response.read()
            except urllib.error.URLError as error:
                refused = isinstance(error.reason, ConnectionRefusedError)
                if not refused or time.monotonic() > deadline:
                    raise
                time.sleep(0.1)

    def start(self) -> threading.Thread:
        """Serve in a background thread until :meth:`shutdown`."""
        thread = threading.Thread(target=self.serve_forever, name="oimi-web-viewer", daemon=True)
        thread.start()
        return thread


class _Handler(BaseHTTPRequestHandler):
    server: PrivateViewer

    def do_GET(self) -> None:
        path, _, query = self.path.partition("?")
        if path in ("/", "/index.html") and "url=" not in query:
            self.send_response(302)
            self.send_header("Location", self.server.url)
            self.end_headers()
            return
        if path == "/":
            path = "/index.html"
        if path != "/index.html" and path not in FORWARDED:
            self.send_error(404)
            return
        try:
            body = self.server.asset(path)
        except OSError as error:
            self.send_error(502, f"Rerun's viewer server: {error}")
            return
        kind = {".js": "text/javascript", ".wasm": "application/wasm", ".svg": "image/svg+xml"}
        suffix = path[path.rfind(".") :]
        self.send_response(200)
        self.send_header("Content-Type", kind.get(suffix, "text/html; charset=utf-8"))
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Content-Security-Policy", content_security_policy(self.server.grpc_port))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, format: str, *args: object) -> None:
        """Quiet: no line per request."""
