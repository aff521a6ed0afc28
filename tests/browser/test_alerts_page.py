"""The Alerts page in a real browser: a person's choice is saved and comes back after a reload;
the history lists what was raised."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.browser.support import fresh_page, login

pytestmark = pytest.mark.browser


def test_a_person_chooses_which_alerts_reach_them(browser, stack):
    errors: list[str] = []
    with fresh_page(browser, viewport={"width": 1366, "height": 800}) as page:
        page.on("pageerror", lambda e: errors.append(str(e)))
        login(page, stack, "olga", next_path="/alerts/")
        form = page.locator("#alert-choice")
        expect(form.locator('[data-field="browsers"]')).to_have_text("(0 browsers)")
        form.locator('input[value="estop"]').check()
        form.locator('input[value="not_responding"]').check()
        form.locator('select[name="min_severity"]').select_option("error")
        form.locator('input[name="by_push"]').check()
        form.locator('button[type="submit"]').click()
        expect(page.locator("#alert-choice-result")).to_have_text("Saved.")
        page.reload()
        expect(form.locator('input[value="estop"]')).to_be_checked()
        expect(form.locator('input[value="not_responding"]')).to_be_checked()
        expect(form.locator('input[value="log"]')).not_to_be_checked()
        expect(form.locator('select[name="min_severity"]')).to_have_value("error")
        expect(form.locator('input[name="by_push"]')).to_be_checked()
        expect(page.locator("#alert-history")).to_be_visible()
    assert errors == []
