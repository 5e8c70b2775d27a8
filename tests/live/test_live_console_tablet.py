"""The console on a tablet, in headless Chromium at the three documented sizes: every
control in view, uncovered and at least 44 px, and usable; keyboard driving for a mouse
user; the lock and the stick held by two fingers at once; the session record's fields.

``OIMI_CONSOLE_SCREENSHOTS=docs`` writes the screenshots of ``docs/live-sessions.md``."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from live_helpers import CHROMIUM, CHROMIUM_FLAGS, Served, require_browser, served
from oimi.pipeline.events import JoystickInput, Topic
from oimi.recorder.reader import open_recording

require_browser()

from playwright.sync_api import Page, expect, sync_playwright  # noqa: E402

SIZES = [(768, 1024), (1024, 768), (1280, 800)]
CONTROLS = ["#plus", "#command", "#restart", "#clear", "#lock", "#stick", "#session"]
TOUCH_PX = 44

# True when the element is inside the viewport, at least 44 px each way, and is what a
# finger at its centre would hit (not the room drawing, not another panel).
REACHABLE = """(el) => {
  const r = el.getBoundingClientRect();
  const x = r.left + r.width / 2, y = r.top + r.height / 2;
  const hit = document.elementFromPoint(x, y);
  return {
    width: r.width, height: r.height,
    inside: r.left >= 0 && r.top >= 0 && r.right <= innerWidth && r.bottom <= innerHeight,
    hit: hit === el || el.contains(hit),
    what: hit ? `${hit.tagName}#${hit.id}.${hit.className}` : "nothing",
  };
}"""


@contextmanager
def console(
    tmp_path: Path, size: tuple[int, int], *flags: str, touch: bool = False
) -> Iterator[tuple[Page, Served]]:
    """``oimi serve`` with a token and the console open at ``size``; page errors fail."""
    width, height = size
    with (
        served(tmp_path / "tablet.mcap", "--token", "t0ken", *flags) as live,
        tempfile.TemporaryDirectory() as profile,
        sync_playwright() as p,
    ):
        context = p.chromium.launch_persistent_context(
            profile,
            executable_path=str(CHROMIUM),
            args=CHROMIUM_FLAGS,
            headless=True,
            viewport={"width": width, "height": height},
            has_touch=touch,
        )
        page = context.new_page()
        errors: list[str] = []
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.goto(f"{live.console}?token=t0ken")
        expect(page.locator("#scenario")).to_have_text("live_room")
        expect(page.locator("#command")).to_be_enabled()
        yield page, live
        context.close()
        assert not errors, errors


def assert_reachable(page: Page, selector: str) -> None:
    box = page.locator(selector).first.evaluate(REACHABLE)
    assert box["inside"], f"{selector} is not entirely in the viewport: {box}"
    assert box["hit"], f"{selector} is covered by {box['what']}"
    assert box["width"] >= TOUCH_PX and box["height"] >= TOUCH_PX, f"{selector}: {box}"


def add(page: Page, activity: str) -> None:
    page.click("#plus")
    page.click(f"#catalogue button[data-activity={activity}]")
    page.click("#picker-add")
    expect(page.locator(f"#selected li[data-name={activity}]")).to_be_visible()


def names(page: Page) -> list[str]:
    return page.locator("#selected li").evaluate_all("(items) => items.map((i) => i.dataset.name)")


def pads(recording: Path) -> list[JoystickInput]:
    rec = open_recording(recording)
    return [
        p
        for m in rec.iter_messages(topics=[Topic.JOYSTICK])
        if isinstance(p := m.decoded(), JoystickInput)
    ]


@pytest.mark.parametrize("size", SIZES, ids=[f"{w}x{h}" for w, h in SIZES])
def test_every_control_is_in_view_uncovered_44px_and_usable(tmp_path: Path, size) -> None:
    width, height = size
    shots = Path(os.environ.get("OIMI_CONSOLE_SCREENSHOTS", tmp_path))
    with console(tmp_path, size, "--child", "C07", "--therapist", "A. Rossi") as (page, live):
        for selector in CONTROLS:
            assert_reachable(page, selector)
        add(page, "example_act")  # + adds an activity
        add(page, "test_dance")
        add(page, "greeting")
        for selector in ("#plus", "#selected li .up", "#selected li .down", "#selected li .trash"):
            assert_reachable(page, selector)
        page.click("#selected li[data-name=example_act] .down")  # reorder by button
        expect(page.locator("#selected li").nth(1)).to_have_attribute("data-name", "example_act")
        assert names(page) == ["test_dance", "example_act", "greeting"]

        command = page.locator("#command")
        command.click()  # Get Ready
        expect(command).to_have_text("Start")
        assert_reachable(page, "#command")
        command.click()
        expect(command).to_have_text("Stop")
        assert_reachable(page, "#command")
        expect(page.locator("#block")).to_contain_text("test_dance")
        page.wait_for_timeout(800)  # the dance lights up for the screenshot
        page.screenshot(path=str(shots / f"console-{width}x{height}.png"))
        command.click()  # Stop
        expect(command).to_have_text("Start")
        for selector in ("#restart", "#clear"):
            assert_reachable(page, selector)
        page.click("#restart")
        expect(page.locator("#message")).not_to_have_class("refused")
        page.click("#clear")
        expect(page.locator("#selected li")).to_have_count(0)
        expect(command).to_have_text("Get Ready")
        live.stop()
    assert live.returncode == 0, live.errors


def test_space_holds_the_lock_arrows_drive_and_letting_go_stops(tmp_path: Path) -> None:
    with console(tmp_path, (1024, 768)) as (page, live):
        page.click("#plus")  # a focused button must not be clicked by Space
        page.click("#picker-cancel")
        page.keyboard.down("Space")
        page.keyboard.down("ArrowUp")
        page.keyboard.down("KeyE")
        expect(page.locator("#lock")).to_have_class("hold lock held")
        expect(page.locator("#engaged")).to_contain_text("engaged")
        expect(page.locator("#lock-state")).to_have_text("Lock engaged (operator drives)")
        page.wait_for_timeout(1000)  # twice the server's silence limit: the heartbeat holds it
        expect(page.locator("#engaged")).to_contain_text("engaged")
        page.keyboard.up("Space")  # the arrow is still down: letting Space go stops anyway
        expect(page.locator("#engaged")).to_have_text("released: the operator let go of the lock")
        expect(page.locator("#lock-state")).to_contain_text("the operator let go of the lock")
        page.keyboard.up("KeyE")
        page.keyboard.up("ArrowUp")
        expect(page.locator("#knob")).to_have_css("top", "58px")  # the stick back at rest
        expect(page.locator("#turn")).to_have_value("0")
        expect(page.locator("#picker")).not_to_have_attribute("open", "")
        live.stop()
    assert live.returncode == 0, live.errors
    recorded = pads(live.recording)
    held = [i for i, p in enumerate(recorded) if p.buttons == ("LB",)]
    assert any((recorded[i].left_y, recorded[i].right_x) == (1.0, 1.0) for i in held), recorded
    released = recorded[held[-1] + 1]
    assert released.buttons == () and released.release == "operator"
    assert not [p for p in recorded if p.release == "heartbeat"], "the heartbeat lapsed"


def test_two_fingers_hold_the_lock_and_drive_the_stick(tmp_path: Path) -> None:
    with console(tmp_path, (768, 1024), touch=True) as (page, live):
        lock = page.locator("#lock").bounding_box()
        stick = page.locator("#stick").bounding_box()
        assert lock and stick
        finger1 = {"x": lock["x"] + lock["width"] / 2, "y": lock["y"] + lock["height"] / 2, "id": 1}
        finger2 = {"x": stick["x"] + stick["width"] / 2, "y": stick["y"] + 4, "id": 2}
        cdp = page.context.new_cdp_session(page)

        def touch(kind: str, *points: dict) -> None:
            cdp.send("Input.dispatchTouchEvent", {"type": kind, "touchPoints": list(points)})

        touch("touchStart", finger1)
        expect(page.locator("#engaged")).to_contain_text("engaged")
        touch("touchStart", finger1, finger2)  # the second finger pushes the stick forward
        expect(page.locator("#knob")).not_to_have_css("top", "58px")
        # hold the push for a few ticks (50 Hz): the session records only the latest pad
        # state of each tick, so a push lifted within one tick would never reach it
        page.wait_for_timeout(300)
        touch("touchEnd", finger2)  # the stick finger lifts; the lock stays held
        expect(page.locator("#knob")).to_have_css("top", "58px")
        expect(page.locator("#lock")).to_have_class("hold lock held")
        page.wait_for_timeout(300)  # the lock alone, held for a few ticks too (same reason)
        touch("touchEnd")
        expect(page.locator("#engaged")).to_have_text("released: the operator let go of the lock")
        live.stop()
    assert live.returncode == 0, live.errors
    recorded = pads(live.recording)
    forward = [p for p in recorded if p.buttons == ("LB",) and p.left_y > 0.9]
    assert forward, recorded
    after = recorded[recorded.index(forward[-1]) + 1 :]
    assert after[0].buttons == ("LB",) and after[0].left_y == 0.0, "the lock outlived the stick"
    assert recorded[-1].buttons == () and recorded[-1].release == "operator"


def test_the_session_fields_from_the_console_end_up_in_the_record(tmp_path: Path) -> None:
    with console(tmp_path, (1280, 800), "--child", "C01", "--notes", "from the flag") as (
        page,
        live,
    ):
        expect(page.locator("#session-summary")).to_have_text("C01")
        page.click("#session")
        expect(page.locator("#field-child")).to_have_value("C01")  # the flags are defaults
        expect(page.locator("#field-notes")).to_have_value("from the flag")
        page.fill("#field-therapist", "B. Bianchi")
        page.fill("#field-notes", "calm; liked the dance\nsecond line")
        page.click("#record-save")
        expect(page.locator("#record")).not_to_have_attribute("open", "")
        expect(page.locator("#session-summary")).to_have_text("C01 · B. Bianchi")
        live.stop()
    assert live.returncode == 0, live.errors
    session = open_recording(live.recording).metadata["session"]
    assert (session["child"], session["therapist"]) == ("C01", "B. Bianchi")
    assert session["notes"] == "calm; liked the dance\nsecond line"
    assert "therapist: B. Bianchi" in live.output
