"""Every page in a real browser, at a desktop and a phone width: one live socket, no errors,
navigation to every page, nothing wider than the screen, no control under another element
(a notice showing included), a compact header on a phone."""

from __future__ import annotations

import re

import pytest
from playwright.sync_api import expect

from tests.browser.checks import COVERED_CONTROLS, HORIZONTAL_OVERFLOW
from tests.browser.support import PHONE, fresh_page, login

pytestmark = pytest.mark.browser

PAGES = {"/": "Dashboard", "/map/": "Map", "/drive/": "Drive", "/history/": "History", "/activity/": "Activity"}
# Linked from every page's navigation but not ours: the API's Swagger UI and Django's admin.
OTHER_PAGES = {"/api/docs/": "API", "/admin/": "Admin"}

# Records the URL of every websocket the document opens.
COUNT_SOCKETS = """(() => {
    const Original = window.WebSocket;
    window.openedSockets = [];
    window.WebSocket = class extends Original {
        constructor(url, ...rest) { super(url, ...rest); window.openedSockets.push(String(url)); }
    };
})()"""
SHOW_NOTICE = """async () => {
    const src = [...document.scripts].find((s) => s.src.includes('/js/header.js')).src;
    const { notify } = await import(src.replace('header.js', 'notices.js'));
    notify('A long notice that must cover no control, card heading or the emergency stop', 'error', {timeout: 0});
}"""


def nav_links(page) -> dict[str, str]:
    return dict(page.eval_on_selector_all(
        ".mainnav a", "links => links.map(a => [new URL(a.href).pathname, a.textContent.trim()])"))


def test_every_page_runs_without_errors_on_one_live_socket(sized_page, stack):
    page = sized_page
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(f"{page.url}: {exc}"))
    page.add_init_script(COUNT_SOCKETS)
    login(page, stack, "ada")
    for path in PAGES:
        page.goto(f"{stack.url}{path}")
        expect(page.locator("#link-pill")).to_have_text("robot online")
        assert page.evaluate("() => 'cyborgLive' in window") is False
        sockets = page.evaluate("() => window.openedSockets")
        assert [url for url in sockets if url.endswith("/ws/live/")] == [sockets[0]], (path, sockets)
    assert errors == []


def test_every_page_fits_the_screen_and_no_control_is_covered_even_by_a_notice(sized_page, stack):
    page = sized_page
    login(page, stack, "ada")
    for path in [*PAGES, "/accounts/login/"]:
        if path == "/accounts/login/":
            page.context.clear_cookies()
        page.goto(f"{stack.url}{path}")
        page.wait_for_load_state("networkidle") if path == "/history/" else page.wait_for_timeout(300)
        if path != "/accounts/login/":
            expect(page.locator("#link-pill")).to_have_text("robot online")
            page.evaluate(SHOW_NOTICE)
            expect(page.locator("#notices .notice-error")).to_be_visible()
        assert page.evaluate(HORIZONTAL_OVERFLOW) <= 0, f"{path} scrolls sideways at {page.viewport['width']} px"
        assert page.evaluate(COVERED_CONTROLS) == [], path


def test_every_page_reaches_every_page_from_its_navigation(sized_page, stack):
    page = sized_page
    phone = page.viewport is PHONE
    login(page, stack, "ada")
    expected = {**PAGES, **OTHER_PAGES}
    paths = list(PAGES)
    for i, path in enumerate(paths):
        page.goto(f"{stack.url}{path}")
        assert nav_links(page) == expected, path
        expect(page.locator(".mainnav a[aria-current=page]")).to_have_text(PAGES[path])
        header = page.locator(".topbar").bounding_box()
        if phone:
            # The header is one compact row; the pages are one tap away behind the menu.
            assert header["height"] <= 60, f"the header takes {header['height']} px on {path}"
            expect(page.locator(".mainnav")).to_be_hidden()
            page.click("#menu-btn")
        expect(page.locator("#estop-btn")).to_be_visible()
        target = paths[(i + 1) % len(paths)]
        page.click(f'.mainnav a[href="{target}"]')
        page.wait_for_url(f"{stack.url}{target}")
    # The pages that are not ours link back: the API docs and the admin.
    for path in OTHER_PAGES:
        page.goto(f"{stack.url}{path}")
        assert page.locator('a[href="/"]').count() >= 1, f"{path} has no way back to the dashboard"


def test_the_header_menu_opens_and_closes_on_a_phone(browser, stack):
    with fresh_page(browser, viewport=PHONE, is_mobile=True, has_touch=True) as page:
        login(page, stack, "vera")
        page.click("#menu-btn")
        expect(page.locator("#menu-btn")).to_have_attribute("aria-expanded", "true")
        expect(page.locator(".mainnav a", has_text="Activity")).to_be_visible()
        expect(page.locator(".who")).to_contain_text("vera")
        page.click("#menu-btn")
        expect(page.locator(".mainnav")).to_be_hidden()
        expect(page.locator("#menu-btn")).to_contain_text(re.compile("Dashboard"))
