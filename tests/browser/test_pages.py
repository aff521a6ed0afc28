"""Every page in a real browser, at a desktop and a phone width."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.browser.support import login

pytestmark = pytest.mark.browser

PAGES = ("/", "/map/", "/drive/", "/history/", "/activity/")


# Records the URL of every websocket the document opens.
COUNT_SOCKETS = """(() => {
    const Original = window.WebSocket;
    window.openedSockets = [];
    window.WebSocket = class extends Original {
        constructor(url, ...rest) { super(url, ...rest); window.openedSockets.push(String(url)); }
    };
})()"""


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
