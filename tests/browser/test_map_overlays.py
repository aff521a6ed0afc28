"""Map overlays in a real browser: the laser scan drawn where the map's walls are, the choice kept per person."""

from __future__ import annotations

import io
import math
import re

import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import expect

from tests.browser.support import login

pytestmark = pytest.mark.browser

SCAN_RGB = (224, 32, 58)  # #e0203a, static/js/map/overlays.js
POSE = (0.0, -1.0, math.pi / 2)  # the hall, facing the north wall's doors and the pillar rows


def api(page, stack, method: str, path: str, body: dict) -> None:
    token = next(c["value"] for c in page.context.cookies() if c["name"] == "csrftoken")
    res = page.request.fetch(f"{stack.url}{path}", method=method, data=body,
                             headers={"X-CSRFToken": token, "Referer": f"{stack.url}/map/"})
    assert res.ok, (res.status, res.text())


def shot(page) -> np.ndarray:
    return np.array(Image.open(io.BytesIO(page.locator("#map-view").screenshot())).convert("RGB")).astype(int)


def test_the_laser_overlay_draws_its_points_on_the_walls_of_the_map(page, stack):
    login(page, stack, "otto", next_path="/map/")
    view = page.locator("#map-view")
    expect(view).to_have_attribute("data-ready", "1")
    api(page, stack, "PATCH", "/api/me/map-overlays/", {"scan": False})
    # A goal left by an earlier test would carry the robot off the known pose.
    api(page, stack, "POST", "/api/navigation/cancel/", {})
    api(page, stack, "POST", "/api/navigation/initial-pose/", dict(zip(("x", "y", "yaw"), POSE, strict=True)))
    page.wait_for_function("([x, y]) => Math.hypot(+document.getElementById('map-view').dataset.robotX - x, "
                           "+document.getElementById('map-view').dataset.robotY - y) < 0.02", arg=list(POSE[:2]))
    page.check('[data-overlay="scan"]')
    expect(view).to_have_attribute("data-scan-points", re.compile(r"^[1-9]\d\d"))
    # a scan taken at the known pose: the laser 0.2 m ahead of the base
    page.wait_for_function("([x, y]) => { const s = window.cyborgMap.overlays.data.scan;"
                           " return s && s.origin && Math.hypot(s.origin[0] - x, s.origin[1] - y) < 0.02; }",
                           arg=[POSE[0], POSE[1] + 0.2])
    page.evaluate("() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)))")
    with_scan = shot(page)
    page.evaluate("() => { document.getElementById('map-overlay').style.visibility = 'hidden'; }")
    map_only = shot(page)
    page.evaluate("() => { document.getElementById('map-overlay').style.visibility = ''; }")

    red = np.argwhere(np.abs(with_scan - SCAN_RGB).sum(axis=2) < 60)
    assert len(red) > 200, f"only {len(red)} scan pixels drawn"
    dark = map_only.sum(axis=2) < 250  # occupied cells are (34, 38, 46)
    h, w = dark.shape
    near_wall = [dark[max(y - 2, 0):min(y + 3, h), max(x - 2, 0):min(x + 3, w)].any() for y, x in red]
    share = sum(near_wall) / len(near_wall)
    assert share > 0.95, f"{100 * share:.0f}% of the scan's pixels lie on the map's walls"


def test_overlay_choices_are_remembered_by_the_server_and_unwatched_when_off(page, stack):
    login(page, stack, "vera", next_path="/map/")
    expect(page.locator("#map-view")).to_have_attribute("data-ready", "1")
    box = page.locator('[data-overlay="particles"]')
    if box.is_checked():
        with page.expect_response(lambda r: "map-overlays" in r.url):
            box.uncheck()
    with page.expect_response(lambda r: "map-overlays" in r.url):
        box.check()
    expect(page.locator('[data-note="particles"]')).to_have_text(re.compile(r"^\d+ particles$"))
    page.reload()
    expect(page.locator('[data-overlay="particles"]')).to_be_checked()
    expect(page.locator('[data-overlay="scan"]')).not_to_be_checked()
    with page.expect_response(lambda r: "map-overlays" in r.url):
        page.locator('[data-overlay="particles"]').uncheck()
    expect(page.locator('[data-note="particles"]')).to_have_text("")
    page.reload()
    expect(page.locator('[data-overlay="particles"]')).not_to_be_checked()
