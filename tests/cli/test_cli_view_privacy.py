"""`oimi view --web` is private: the page it prints opens the recording, and loading it in a
real browser makes no request to another machine (Rerun's analytics, update check,
examples manifest and web font are never attempted)."""

from __future__ import annotations

import os
import urllib.request
from pathlib import Path

import pytest
from oimi.scenarios.loader import parse_scenario
from oimi.scenarios.session.recording import recorded
from oimi.scenarios.session.runner import Session
from viewer_browser import REFUSED, browser, missing, viewing, wait_until

from oimi.web_viewer import GUARD, content_security_policy, private_page

SCENARIO = b"""\
name = "private"
seed = 3
duration_s = 2.0
[robot]
x_m = 3.0
y_m = 2.5
[[humans]]
id = "child"
x_m = 4.5
y_m = 2.6
[[activities]]
generator = "greeting"
"""


def test_the_page_loses_its_remote_links_and_gets_the_guard_first() -> None:
    html = (
        "<html><head><meta charset=utf-8>\n"
        '<link rel="preconnect" href="https://fonts.googleapis.com" />\n'
        '<link href="https://fonts.googleapis.com/css2?family=Inter" rel="stylesheet" />\n'
        '<link rel="icon" href="favicon.svg" />\n'
        "</head><body><script src=re_viewer.js></script></body></html>"
    )
    page = private_page(html)
    assert "https://" not in page.replace(GUARD, "")
    assert 'href="favicon.svg"' in page
    assert page.index(GUARD) < page.index("<meta") < page.index("re_viewer.js")
    policy = content_security_policy(9876)
    assert "connect-src 'self' http://127.0.0.1:9876 " in policy
    assert "default-src 'self'" in policy and "https:" not in policy


if (why := missing()) is not None:
    if os.environ.get("OIMI_REQUIRE_BROWSER") == "1":
        raise RuntimeError(f"OIMI_REQUIRE_BROWSER=1 but {why}")
    pytest.skip(f"browser tests skipped: {why}", allow_module_level=True)


@pytest.fixture(scope="module")
def mcap(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("private")
    session = Session(parse_scenario(SCENARIO, source=folder / "private.toml"))
    path = folder / "private.mcap"
    with recorded(session, mcap=path, rrd=None):
        session.run()
    return path


def test_the_web_viewer_asks_nothing_of_another_machine(mcap: Path) -> None:
    with viewing(mcap) as (url, grpc, web):
        proxy = "rerun%2Bhttp%3A%2F%2F127.0.0.1%3A" + str(grpc) + "%2Fproxy"
        assert url == f"http://127.0.0.1:{web}/?url={proxy}&hide_welcome_screen"
        with urllib.request.urlopen(f"http://127.0.0.1:{web}/", timeout=30) as bare:
            assert bare.url == url, "the bare address redirects to the recording"
        with browser(1280, 800) as (page, traffic):
            page.goto(url)
            # The viewer tried its update check and analytics, and the guard refused both
            # inside the page; the recording streamed in from loopback.
            assert wait_until(
                page,
                lambda: (
                    traffic.refused("api.github.com")
                    and traffic.refused("tel.rerun.io")
                    and any("ReadMessages" in r for r in traffic.requests)
                ),
                seconds=120,
            ), (traffic.requests, [t for t in traffic.console if REFUSED in t])
            page.wait_for_timeout(2000)
    assert traffic.external == []
    assert f"http://127.0.0.1:{web}/re_viewer_bg.wasm" in traffic.requests
    assert not [t for t in traffic.console if "Content Security Policy" in t]
