"""The dashboard's Mode row says which mode was asked for and whether it was reached, and a
mode is reached from inside behaviour (Behaviour → Demo once needed Stop first)."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.browser.support import login

pytestmark = pytest.mark.browser


def test_the_mode_row_follows_a_change_from_behaviour_to_demo(sized_page, stack):
    page = sized_page
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    login(page, stack, "otto")
    mode_row = page.locator('[data-card="state_change"] [data-field="mode.requested"]')
    state = page.locator('[data-field="smach.current"]')
    page.locator('[data-mode="behaviour"]').click()
    expect(mode_row).to_have_text("behaviour · reached", timeout=10_000)
    expect(state).to_have_text("idle")
    page.locator('[data-mode="demo"]').click()
    expect(mode_row).to_have_text("demo · reached", timeout=10_000)
    expect(state).to_have_text("demo")
    page.reload()
    expect(mode_row).to_have_text("demo · reached")
    page.locator('[data-mode="stop"]').click()  # leave the shared robot where the others expect it
    expect(mode_row).to_have_text("stop · reached", timeout=10_000)
    assert errors == []
