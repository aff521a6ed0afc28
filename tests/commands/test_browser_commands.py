"""Real browser, real stack: the mode commander from the dashboard, per role."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.browser.support import login

pytestmark = pytest.mark.browser

MODES = ("behaviour", "demo", "manual", "stop")


def test_it_switches_to_manual_when_an_operator_clicks_manual(page, stack):
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    login(page, stack, "otto")
    state = page.locator('[data-field="smach.current"]')
    # Start from a known state whatever earlier tests did to the shared robot (a restarted
    # robot first finishes its startup).
    expect(state).not_to_have_text("startup", timeout=30_000)
    page.click('[data-mode="stop"]')
    expect(page.locator('#card-mode [data-field="mode.request"]')).to_have_text("stop by otto · reached")
    expect(state).to_have_text("suspension")
    page.click('[data-mode="manual"]')
    expect(state).to_have_text("manual", timeout=30_000)  # a loaded machine: the robot answers late
    expect(page.locator('#card-mode [data-field="mode.request"]')).to_have_text("manual by otto · reached")
    expect(page.locator('#card-mode [data-field="mode.reached"]')).to_have_text("manual ✓")
    expect(page.locator('[data-mode="manual"]')).to_have_attribute("aria-pressed", "true")
    expect(page.locator('[data-field="mode.mismatch"]')).to_be_hidden()
    # The events the new state accepts are offered, and the emotion system went off.
    expect(page.locator("#card-events .event-btn", has_text="aborted → suspension")).to_be_visible()
    expect(page.locator('[data-field="emotion.system"]')).to_have_text("system off")
    assert errors == []


def test_it_speaks_and_reports_bad_input_from_the_page(page, stack):
    login(page, stack, "olga")
    page.fill("#card-voice textarea[name=text]", "Hello from the browser")
    page.click("#card-voice button[type=submit]")
    expect(page.locator('[data-field="tts.last"]')).to_have_text("Hello from the browser")
    expect(page.locator("#card-voice textarea[name=text]")).to_have_value("")
    # Text with a character nobody sees (a zero-width joiner): refused with a notice naming it, not spoken.
    page.fill("#card-voice textarea[name=text]", "Hello\u200dthere")
    page.click("#card-voice button[type=submit]")
    expect(page.locator(".notice-error")).to_contain_text(
        "text: contains an invisible formatting character (U+200D ZERO WIDTH JOINER)")
    expect(page.locator('[data-field="tts.last"]')).to_have_text("Hello from the browser")
    page.locator("#notices .notice-error").evaluate_all("notices => notices.forEach((n) => n.remove())")
    # An event the server refuses: the notice names the field, nothing is sent.
    page.evaluate("document.querySelector('#card-events input[name=event]').removeAttribute('pattern')")
    page.fill("#card-events input[name=event]", "not valid!")
    page.click("#card-events form button[type=submit]")
    expect(page.locator(".notice-error")).to_contain_text("event: use letters, digits and '_' only.")


def test_it_shows_viewers_disabled_controls(page, stack):
    login(page, stack, "vera")
    for mode in MODES:
        expect(page.locator(f'[data-mode="{mode}"]')).to_be_disabled()
    expect(page.locator("#card-voice textarea[name=text]")).to_be_disabled()
    expect(page.locator("#card-mode [data-command=motors]").first).to_be_disabled()
    expect(page.locator("[data-viewer-note]")).to_contain_text("can watch but not command")
    # Live values still arrive for viewers, and so do the events (as disabled buttons).
    expect(page.locator("#card-events .event-btn").first).to_be_disabled(timeout=15_000)
