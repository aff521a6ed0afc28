"""The Connect a ROS tool page in a real browser: unmodified roslibjs (vendored) gets a ticket and
connects through the front door, lists the robot's topics through rosapi and shows a live value;
the ticket the page shows works once."""

from __future__ import annotations

import re

import pytest
from playwright.sync_api import expect

from tests.browser.support import login

pytestmark = pytest.mark.browser


def test_roslibjs_in_a_page_connects_through_the_front_door_and_watches_a_topic(stack, page):
    login(page, stack, "vera", next_path="/rosbridge-tools/")
    page.click("#frontdoor-check")
    expect(page.locator("#frontdoor-state")).to_have_text("Connected through the front door.", timeout=20_000)
    expect(page.locator("#frontdoor-topics")).to_have_text(re.compile(r"^[1-9]\d*$"), timeout=20_000)
    expect(page.locator("#frontdoor-value")).to_have_text(re.compile(r"^0(\.\d+)?$|^1(\.0+)?$"), timeout=20_000)


def test_the_page_shows_a_ticket_address_that_works_once(stack, page):
    login(page, stack, "vera", next_path="/rosbridge-tools/")
    page.click("#frontdoor-ticket")
    url = page.locator("#frontdoor-url")
    expect(url).to_have_text(re.compile(r"^ws://.+/rosbridge/\?ticket=\S+$"))
    address = url.text_content()
    opened = page.evaluate("""(address) => new Promise((resolve) => {
        const attempt = (then) => { const ws = new WebSocket(address);
            ws.onopen = () => { ws.close(); then(true); }; ws.onerror = () => then(false); };
        attempt((first) => attempt((second) => resolve([first, second])));
    })""", address)
    assert opened == [True, False]
