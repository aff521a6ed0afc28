"""The map page's named locations: headings in degrees, and "At location" names a place the
server knows even when the robot's own navigation node does not."""

from __future__ import annotations

import math
import re

import pytest
from playwright.sync_api import expect

from tests.browser.support import login

pytestmark = pytest.mark.browser


def api_post(page, stack, path: str, body: dict) -> None:
    token = next(c["value"] for c in page.context.cookies() if c["name"] == "csrftoken")
    res = page.request.post(f"{stack.url}{path}", data=body, headers={"X-CSRFToken": token,
                                                                      "Referer": f"{stack.url}/map/"})
    assert res.ok, (res.status, res.text())


def test_arriving_at_a_place_only_the_server_knows_shows_its_name(sized_page, stack):
    page = sized_page
    name = f"bench_{page.viewport_size['width']}"
    page.on("dialog", lambda d: d.accept())
    login(page, stack, "otto", next_path="/map/")
    expect(page.locator("#map-view")).to_have_attribute("data-robot-x", re.compile(r"^-?\d"))
    # A goal left by an earlier test would carry the robot off the pose set below.
    api_post(page, stack, "/api/navigation/cancel/", {})
    # Somewhere none of the robot's own places is, facing up the map.
    api_post(page, stack, "/api/navigation/initial-pose/", {"x": -3.0, "y": 0.0, "yaw": math.pi / 2})
    view = page.locator("#map-view")
    # Save only once the page shows the robot there: "(none)" alone also holds wherever it was before.
    expect(view).to_have_attribute("data-robot-x", re.compile(r"^-(2\.9[5-9]|3\.0[0-5])"), timeout=10_000)
    expect(view).to_have_attribute("data-robot-y", re.compile(r"^-?0\.0[0-5]"), timeout=10_000)
    here = page.locator("#current-location")
    expect(here).to_have_text("(none)", timeout=10_000)
    page.fill("#save-pose-name", name)
    page.locator("#save-pose-form button[type=submit]").click()
    entry = page.locator(f'#location-list li[data-location="{name}"]')
    expect(entry).to_contain_text("· 90°")
    expect(here).to_have_text(name, timeout=10_000)
    # Tidy up: the location goes, and the robot returns to its own reception.
    entry.get_by_role("button", name=f"Delete {name}").click()
    expect(entry).to_have_count(0)
    api_post(page, stack, "/api/navigation/initial-pose/", {"x": 0.0, "y": -1.0, "yaw": -math.pi / 2})
    expect(here).to_have_text("reception", timeout=10_000)
