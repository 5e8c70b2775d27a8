"""The web console in a real browser (headless Chromium from Debian, driven by Playwright)
against ``oimi serve``: the operator's whole round of thesis 5.1, and the joystick."""

from __future__ import annotations

import contextlib
import json
import os
import re
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from live_helpers import CHROMIUM, CHROMIUM_FLAGS, ROOT, LineClient, require_browser, served
from oimi.pipeline.events import JoystickInput, Topic
from oimi.recorder.reader import open_recording
from oimi.replay.redrive import redrive

require_browser()

from playwright.sync_api import Page, WebSocketRoute, expect, sync_playwright  # noqa: E402


@pytest.fixture
def browser_page():
    with tempfile.TemporaryDirectory() as profile, sync_playwright() as p:
        context = p.chromium.launch_persistent_context(
            profile,
            executable_path=str(CHROMIUM),
            args=CHROMIUM_FLAGS,
            headless=True,
            viewport={"width": 1400, "height": 760},
        )
        page = context.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda error: errors.append(str(error)))
        yield page
        context.close()
        assert not errors, errors


def add(page: Page, activity: str, **options: str) -> None:
    page.click("#plus")
    page.click(f"#catalogue button[data-activity={activity}]")
    for name, value in options.items():
        page.fill(f"#options [name={name}]", value)
    page.click("#picker-add")
    expect(page.locator(f"#selected li[data-name={activity}]")).to_be_visible()


@contextlib.contextmanager
def console_open(page: Page, recording: Path) -> Iterator[None]:
    """``oimi serve`` recording to ``recording``, its console open in ``page``."""
    with served(recording, "--token", "t0ken") as live:
        page.goto(f"{live.console}?token=t0ken")
        expect(page.locator("#scenario")).to_have_text("live_room")
        yield


def item(page: Page, activity: str):
    return page.locator(f"#selected li[data-name={activity}]")


def test_console_runs_a_session_and_the_recording_replays_clean(browser_page, tmp_path):
    page = browser_page
    recording = tmp_path / "console.mcap"
    screenshot = Path(os.environ.get("OIMI_CONSOLE_SCREENSHOT", tmp_path / "console.png"))
    with served(recording, "--token", "t0ken") as live:  # the console sends it from its URL
        page.goto(f"{live.console}?token=t0ken")
        expect(page.locator("body")).to_have_attribute("data-link", "up")
        expect(page.locator("#scenario")).to_have_text("live_room")  # the hello after auth
        command = page.locator("#command")
        expect(command).to_have_attribute("data-button", "get_ready")

        page.click("#plus")  # the dance's option screen: tempo and colours
        page.click("#catalogue button[data-activity=test_dance]")
        expect(page.locator("#options [name=colours]")).to_have_value("red,green,blue")
        page.fill("#options [name=tempo]", "lively")
        page.click("#picker-add")
        expect(page.locator("#picker-message")).to_contain_text("tempo")
        page.click("#picker-cancel")

        add(page, "example_act", colour="cyan")
        add(page, "test_dance", tempo="slow", colours="orange,purple")
        add(page, "greeting")
        expect(item(page, "test_dance")).to_contain_text("orange,purple")
        command.click()  # Get Ready
        expect(command).to_have_attribute("data-button", "start")
        expect(command).to_have_text("Start")
        command.click()
        expect(command).to_have_text("Stop")
        expect(item(page, "example_act")).to_have_attribute("data-state", "completed")
        expect(item(page, "test_dance")).to_have_attribute("data-state", "current")
        expect(item(page, "greeting")).to_have_attribute("data-state", "not_yet_completed")
        expect(page.locator("#restart")).to_be_disabled()
        expect(page.locator("#block")).to_contain_text("test_dance")
        page.wait_for_timeout(1200)  # the dance lights up
        page.screenshot(path=str(screenshot))

        command.click()  # Stop
        expect(command).to_have_text("Start")
        expect(item(page, "test_dance")).to_have_attribute("data-state", "not_yet_completed")
        item(page, "greeting").drag_to(item(page, "example_act"))  # reorder: greeting first
        expect(page.locator("#selected li").first).to_have_attribute("data-name", "greeting")
        page.click("#selected li[data-name=greeting] .trash")
        expect(item(page, "greeting")).to_have_count(0)
        page.click("#restart")
        expect(item(page, "example_act")).to_have_attribute("data-state", "not_yet_completed")
        page.click("#clear")
        expect(page.locator("#selected li")).to_have_count(0)
        expect(command).to_have_text("Get Ready")

        # The on-screen joystick: hold the lock and push; letting go stops the robot.
        lock = page.locator("#lock")
        lock.hover()
        page.mouse.down()
        expect(page.locator("#engaged")).to_contain_text("engaged")
        page.mouse.up()
        expect(page.locator("#engaged")).to_have_text("released: the operator let go of the lock")

        # Drive at the child standing 1.7 m ahead (keyboard: Space and the up arrow): the
        # safety supervisor slows the robot near them, and the console says so.
        expect(page.locator("#safety")).to_have_text("–")
        page.keyboard.down("Space")
        page.keyboard.down("ArrowUp")
        expect(page.locator("#safety")).to_have_text(
            re.compile(r"(slowing near|protective stop: nothing moves towards) child \(joystick\)"),
            timeout=15_000,
        )
        page.keyboard.up("ArrowUp")
        page.keyboard.up("Space")
        expect(page.locator("#engaged")).to_have_text("released: the operator let go of the lock")
        live.stop()
    assert live.returncode == 0, live.errors

    rec = open_recording(recording)
    pads = [m.decoded() for m in rec.iter_messages(topics=[Topic.JOYSTICK])]
    assert [p.buttons for p in pads if isinstance(p, JoystickInput)][-2:] == [("LB",), ()]
    assert pads[-1].release == "operator"  # type: ignore[union-attr]
    verbs = [
        c.verb
        for m in rec.iter_messages(topics=[Topic.OPERATOR_COMMANDS])
        for c in m.decoded().commands  # type: ignore[attr-defined]
    ]
    assert [v for v in verbs if v not in ("list", "add")] == [
        "get_ready",
        "start",
        "stop",
        "reorder",
        "remove",
        "restart",
        "clear",
    ]
    comparison = redrive(recording)
    assert comparison.ok, comparison.divergence


def test_a_catalogue_that_arrives_late_leaves_the_options_being_filled(browser_page, tmp_path):
    """ "+" shows the catalogue it has and asks for a fresh one; a reply that arrives after
    the therapist chose an activity must not throw them back to the list."""
    page = browser_page
    held: list[str | bytes] = []
    routes: dict[str, Any] = {"hold": False, "passed": 0, "after": 0}

    def route(ws: WebSocketRoute) -> None:
        server = ws.connect_to_server()
        routes["page"] = ws

        def from_server(message: str | bytes) -> None:
            if '"catalogue"' in str(message):
                if routes["hold"]:
                    held.append(message)  # the reply to "+"'s fresh list, kept back
                    return
                routes["passed"] += 1
            ws.send(message)
            routes["after"] += 1

        server.on_message(from_server)
        ws.on_message(server.send)

    page.route_web_socket("**/ws", route)
    with console_open(page, tmp_path / "late.mcap"):
        _within_5_s(page, lambda: routes["passed"] == 1)  # the catalogue asked for on connecting
        routes["hold"] = True
        page.click("#plus")
        page.click("#catalogue button[data-activity=test_dance]")
        page.fill("#options [name=tempo]", "slow")
        expect(page.locator("#picker-add")).to_be_visible()
        _within_5_s(page, lambda: len(held) == 1)  # "+" asked for a fresh one: kept back
        routes["hold"] = False
        routes["page"].send(held.pop())  # now it arrives, late
        routes["after"] = 0  # the world streams on: two more messages behind it, in order
        _within_5_s(page, lambda: routes["after"] >= 2)
        page.wait_for_timeout(200)
        expect(page.locator("#picker-add")).to_be_visible()
        expect(page.locator("#options [name=tempo]")).to_have_value("slow")
        page.click("#picker-add")
        expect(item(page, "test_dance")).to_be_visible()


class FirstReplyHeld:
    """Routes the console's WebSocket and keeps back the server's reply to the first
    request of ``cmd`` until :meth:`release` (then counts the messages that follow)."""

    def __init__(self, page: Page, cmd: str) -> None:
        self.cmd = cmd
        self.request_id: int | None = None
        self.held: list[str | bytes] = []
        self.after = 0
        self._page_side: WebSocketRoute | None = None
        page.route_web_socket("**/ws", self._route)

    def _route(self, ws: WebSocketRoute) -> None:
        server = ws.connect_to_server()
        self._page_side = ws

        def from_page(message: str | bytes) -> None:
            body = json.loads(message)
            if body.get("cmd") == self.cmd and self.request_id is None:
                self.request_id = body["id"]
            server.send(message)

        def from_server(message: str | bytes) -> None:
            first = self.request_id is not None and not self.held
            if first and json.loads(message).get("id") == self.request_id:
                self.held.append(message)  # the reply to the first request, kept back
                return
            ws.send(message)
            self.after += 1

        server.on_message(from_server)
        ws.on_message(from_page)

    def release(self, page: Page) -> None:
        """Send the held reply, late, and let two more messages follow it."""
        assert self._page_side is not None
        self._page_side.send(self.held.pop())
        self.after = 0
        _within_5_s(page, lambda: self.after >= 2)
        page.wait_for_timeout(200)


def test_a_late_reply_to_add_leaves_a_picker_reopened_for_another_choice(browser_page, tmp_path):
    """Add, then Cancel and "+" for another activity before the reply: the reply must not
    close the new choice's picker (the first activity is still added, and said)."""
    page = browser_page
    reply = FirstReplyHeld(page, "add")
    with console_open(page, tmp_path / "late-add.mcap"):
        page.click("#plus")
        page.click("#catalogue button[data-activity=example_act]")
        page.click("#picker-add")
        _within_5_s(page, lambda: len(reply.held) == 1)
        page.click("#picker-cancel")
        page.click("#plus")
        page.click("#catalogue button[data-activity=test_dance]")
        reply.release(page)  # the first add's reply arrives, late
        expect(page.locator("#picker-add")).to_be_visible()
        expect(page.locator("#options [name=tempo]")).to_be_visible()
        expect(item(page, "example_act")).to_be_visible()


def test_a_late_reply_to_the_session_record_leaves_a_record_reopened_meanwhile(
    browser_page, tmp_path
):
    """Save, then Cancel and open the record again to type more before the reply: the
    reply must not close it nor overwrite what is being typed (what was saved is shown)."""
    page = browser_page
    reply = FirstReplyHeld(page, "session")
    with console_open(page, tmp_path / "late-record.mcap"):
        page.click("#session")
        page.fill("#field-child", "C07")
        page.click("#record-save")
        _within_5_s(page, lambda: len(reply.held) == 1)
        page.click("#record-cancel")
        page.click("#session")
        page.fill("#field-notes", "tired today")
        reply.release(page)  # the first save's reply arrives, late
        expect(page.locator("#record")).to_be_visible()
        expect(page.locator("#field-notes")).to_have_value("tired today")
        expect(page.locator("#session-summary")).to_have_text("C07")


def _within_5_s(page: Page, done: Callable[[], bool]) -> None:
    """Let the page run until ``done()`` (a bounded wait over loopback)."""
    for _ in range(50):
        if done():
            return
        page.wait_for_timeout(100)
    raise AssertionError("not within 5 s")


def test_the_clock_runs_with_the_session_between_operator_changes(browser_page, tmp_path):
    """The operator's state is sent when it changes; the room's frames, ten a second, carry
    the time too: the clock read the first only, so it stood still while nothing was asked
    of the session (a child walking out of the room at "t = 6.5 s" for a minute)."""
    page = browser_page
    scenario = ROOT / "scenarios" / "library" / "idle_alone.toml"  # one long idle block
    with served(tmp_path / "clock.mcap", "--token", "t0ken", scenario=scenario) as live:
        page.goto(f"{live.console}?token=t0ken")
        clock = page.locator("#clock")
        expect(clock).to_have_text(re.compile(r"t = \d+\.\d s"))
        shown = set()
        for _ in range(10):  # two seconds: the idle activity's block lasts 4.5 s
            shown.add(clock.text_content())
            page.wait_for_timeout(200)
        assert len(shown) >= 5, shown


def test_a_rules_switch_shows_the_current_activity_paused(browser_page, tmp_path):
    """child_leaves: the child walks off during play_together and child_left switches to
    wait_for_child. The list said play_together was current all the while; it waits."""
    page = browser_page
    scenario = ROOT / "scenarios" / "library" / "child_leaves.toml"
    screenshot = Path(os.environ.get("OIMI_PAUSED_SCREENSHOT", tmp_path / "paused.png"))
    with served(tmp_path / "paused.mcap", "--token", "t0ken", scenario=scenario) as live:
        page.goto(f"{live.console}?token=t0ken")
        command = page.locator("#command")
        expect(command).to_have_attribute("data-button", "get_ready")
        command.click()
        expect(command).to_have_attribute("data-button", "start")
        command.click()
        play = item(page, "play_together")
        expect(play).to_have_attribute("data-state", "current")
        badge = play.locator(".state")
        expect(badge).to_have_text("current")
        # the child leaves at 4 s of the session and is 3 m off about 2.5 s later
        expect(badge).to_have_text("paused: wait_for_child runs", timeout=20_000)
        expect(play).to_have_class("current paused")
        expect(page.locator("#block")).to_contain_text("wait_for_child")
        page.screenshot(path=str(screenshot))


def test_the_newest_warning_is_the_one_in_view(browser_page, tmp_path):
    """The warnings list is a few lines high and holds the latest eight: newest last, the
    operator saw the oldest ones and had to scroll for the one their last press caused."""
    page = browser_page
    with served(tmp_path / "warnings.mcap", "--token", "t0ken") as live:
        page.goto(f"{live.console}?token=t0ken")
        expect(page.locator("#scenario")).to_have_text("live_room")
        assert live.tcp_port is not None
        client = LineClient.connect(live.tcp_port)
        client.read()  # the hello
        assert client.call(cmd="auth", token="t0ken")["ok"]
        for n in range(8):
            assert not client.call(cmd="remove", activity=f"nothing_{n}")["ok"]
        client.close()
        newest = page.locator("#log li", has_text="'nothing_7' is not selected")
        expect(newest).to_be_in_viewport()
        expect(page.locator("#log li").first).to_have_text(re.compile("nothing_7"))
