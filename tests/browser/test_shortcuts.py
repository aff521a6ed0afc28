"""The keyboard-shortcut help: "?" on any page lists that page's keys (Drive's driving keys, the talk
key, the state machine's transitions, the E-STOP's Esc for operators), and "?" or Close hides it."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.browser.support import login

pytestmark = pytest.mark.browser


def help_text(page) -> str:
    page.keyboard.press("?")
    dialog = page.locator("#shortcuts")
    expect(dialog).to_be_visible()
    text = dialog.inner_text()
    page.keyboard.press("?")
    expect(dialog).to_be_hidden()
    return text


def test_each_page_lists_its_own_shortcuts(sized_page, stack):
    page = sized_page
    login(page, stack, "otto", next_path="/drive/")
    page.locator("#drive h2").click()  # focus on the page, not in a field
    drive = help_text(page)
    for words in ("W", "drive forward", "turn left", "T", "talk through the robot's speakers", "Esc", "E-STOP", "?"):
        assert words in drive, (words, drive)

    page.goto(f"{stack.url}/statemachine/")
    machine = help_text(page)
    assert "send the focused transition's event" in machine and "drive forward" not in machine

    page.goto(f"{stack.url}/history/")
    page.keyboard.press("?")
    expect(page.locator("#shortcuts")).to_be_visible()
    page.locator("#shortcuts button", has_text="Close").click()
    expect(page.locator("#shortcuts")).to_be_hidden()
    # Typed into a field, "?" is a character, not the help.
    page.locator("#topic").focus()
    page.keyboard.press("?")
    expect(page.locator("#shortcuts")).to_be_hidden()


def test_a_viewer_is_not_offered_the_estop_or_driving_keys(browser, stack):
    from tests.browser.support import fresh_page

    with fresh_page(browser, viewport={"width": 1366, "height": 800}) as page:
        login(page, stack, "vera", next_path="/drive/")
        text = help_text(page)
        assert "E-STOP" not in text and "drive forward" not in text and "?" in text


def test_esc_in_the_help_closes_it_and_leaves_the_estop_released(page, stack):
    login(page, stack, "otto")
    latched = lambda: page.request.get(f"{stack.url}/api/robot/estop/").json()["latched"]  # noqa: E731
    assert not latched()
    page.keyboard.press("?")
    dialog = page.locator("#shortcuts")
    expect(dialog).to_be_visible()
    assert "stop the robot" in dialog.inner_text() and "Esc" in dialog.inner_text()
    page.keyboard.press("Escape")
    expect(dialog).to_be_hidden()
    # A press would have marked the button at once (it is pressed in the key's own handler).
    button = page.locator("#estop-btn")
    assert button.get_attribute("aria-busy") is None and button.get_attribute("data-result") is None
    page.wait_for_load_state("networkidle")
    assert not latched()
    expect(page.locator("#estop-banner")).to_be_hidden()

    # With no dialog open, Esc is the E-STOP again.
    token = next(c["value"] for c in page.context.cookies() if c["name"] == "csrftoken")
    try:
        page.keyboard.press("Escape")
        expect(page.locator("#estop-banner")).to_be_visible()
        assert latched()
    finally:
        for path, body in (("/api/robot/estop/release/", {"confirm": True}), ("/api/robot/motors/", {"enabled": True})):
            page.request.post(f"{stack.url}{path}", data=body, headers={"X-CSRFToken": token})
