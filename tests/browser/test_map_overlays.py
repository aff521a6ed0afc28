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
    # The legend's swatch is the colour the scan is drawn in.
    swatch = page.evaluate("""() => getComputedStyle(document.querySelector('.swatch.ov-scan')).backgroundColor""")
    scan_rgb = tuple(int(v) for v in re.findall(r"\d+", swatch)[:3])
    # a scan taken at the known pose: the laser 0.2 m ahead of the base
    page.wait_for_function("([x, y]) => { const s = window.cyborgMap.overlays.data.scan;"
                           " return s && s.origin && Math.hypot(s.origin[0] - x, s.origin[1] - y) < 0.02; }",
                           arg=[POSE[0], POSE[1] + 0.2])
    page.evaluate("() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)))")
    with_scan = shot(page)
    page.evaluate("() => { document.getElementById('map-overlay').style.visibility = 'hidden'; }")
    map_only = shot(page)
    page.evaluate("() => { document.getElementById('map-overlay').style.visibility = ''; }")

    dots = np.argwhere(np.abs(with_scan - scan_rgb).sum(axis=2) < 60)
    assert len(dots) > 400, f"only {len(dots)} scan pixels drawn"  # dots of a few pixels across, not 1 px
    dark = map_only.sum(axis=2) < 250  # occupied cells are (34, 38, 46)
    h, w = dark.shape
    # A dot's pixels lie within its radius (3.5 px at most) of the wall it marks.
    near_wall = [dark[max(y - 4, 0):min(y + 5, h), max(x - 4, 0):min(x + 5, w)].any() for y, x in dots]
    share = sum(near_wall) / len(near_wall)
    assert share > 0.95, f"{100 * share:.0f}% of the scan's pixels lie on the map's walls"

    # On the global costmap the dots still show, as many as on the bare map (its cells are never that colour).
    page.check('[data-overlay="global_costmap"]')
    expect(page.locator('[data-note="global_costmap"]')).to_contain_text("cells")
    page.wait_for_timeout(1500)  # its tiles load
    on_costmap = np.argwhere(np.abs(shot(page) - scan_rgb).sum(axis=2) < 60)
    page.uncheck('[data-overlay="scan"]')
    page.wait_for_timeout(300)
    costmap_only = np.argwhere(np.abs(shot(page) - scan_rgb).sum(axis=2) < 60)
    page.uncheck('[data-overlay="global_costmap"]')
    assert len(on_costmap) > 0.8 * len(dots), (len(on_costmap), len(dots))
    assert len(costmap_only) < 0.05 * len(dots), f"{len(costmap_only)} costmap pixels look like the scan"


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
