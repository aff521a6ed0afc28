import re

import pytest
from playwright.sync_api import expect

from tests.browser.support import login

pytestmark = pytest.mark.browser


def test_it_shows_the_battery_changing_without_reload(page, stack):
    login(page, stack, "vera")
    battery = page.locator('[data-field="battery.percent"]')
    expect(battery).to_have_text(re.compile(r"^\d+\.\d %$"))
    first = battery.inner_text()
    navigations = []
    page.on("framenavigated", lambda frame: navigations.append(frame.url))
    # The simulator drains the battery continuously; the value must change in place.
    expect(battery).not_to_have_text(first, timeout=20_000)
    assert navigations == []
    expect(page.locator("#link-pill")).to_have_text("robot online")


def test_it_sends_anonymous_visitors_to_the_login_page(page, stack):
    page.goto(f"{stack.url}/")
    assert "/accounts/login/" in page.url
    expect(page.locator("h1")).to_have_text("Log in")


def test_it_fits_a_phone_screen(browser, stack):
    context = browser.new_context(viewport={"width": 390, "height": 844}, is_mobile=True, has_touch=True)
    page = context.new_page()
    try:
        login(page, stack, "vera")
        expect(page.locator('[data-field="battery.percent"]')).to_have_text(re.compile(r"%$"))
        overflow = page.evaluate("document.documentElement.scrollWidth - window.innerWidth")
        assert overflow <= 0, f"page is {overflow}px wider than a phone screen"
    finally:
        context.close()
