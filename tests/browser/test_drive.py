"""Drive the simulated robot from the manual control page in a real browser."""

import math

import pytest
from playwright.sync_api import expect

from tests.browser.support import login

pytestmark = pytest.mark.browser


def _ready_to_drive(page, stack) -> None:
    """Other browser tests share the robot: no goal, motors on, at reception facing the clear hall."""
    token = next(c["value"] for c in page.context.cookies() if c["name"] == "csrftoken")
    for path, body in (("/api/navigation/cancel/", {}), ("/api/robot/motors/", {"enabled": True}),
                       ("/api/navigation/initial-pose/", {"x": 0.0, "y": -1.0, "yaw": math.pi / 2})):
        response = page.request.post(f"{stack.url}{path}", data=body, headers={"X-CSRFToken": token})
        assert response.ok, (path, response.status, response.text())


def _pose(page) -> tuple[float, float]:
    data = page.locator("#pose").evaluate("el => [el.dataset.x, el.dataset.y]")
    return float(data[0]), float(data[1])


def test_it_drives_forward_while_w_is_held_and_stops_on_release(page, stack):
    errors = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    login(page, stack, "otto", next_path="/drive/")
    _ready_to_drive(page, stack)
    expect(page.locator("#lock-state")).to_have_text("Nobody is driving")
    expect(page.locator("#pose")).not_to_have_attribute("data-x", "")
    expect(page.locator("#motors")).to_have_text("enabled")
    page.wait_for_function("() => { const el = document.getElementById('pose');"
                           " return Math.hypot(Number(el.dataset.x), Number(el.dataset.y) + 1) < 0.05; }")
    start = _pose(page)

    page.locator("#drive h2").click()  # the page has the keyboard
    page.keyboard.down("w")
    expect(page.locator("#lock-state")).to_have_text("You are driving")
    page.wait_for_function(
        "([x, y]) => { const el = document.getElementById('pose');"
        " return Math.hypot(el.dataset.x - x, el.dataset.y - y) > 0.3; }",
        arg=list(start), timeout=10_000,
    )
    expect(page.locator("#odom-vel")).not_to_have_attribute("data-linear", "0")
    page.keyboard.up("w")

    expect(page.locator("#cmd-vel")).to_have_attribute("data-linear", "0")
    expect(page.locator("#odom-vel")).to_have_attribute("data-linear", "0", timeout=5_000)
    stopped = _pose(page)
    page.wait_for_timeout(600)  # long enough for a runaway robot to show on the 10 Hz pose
    assert math.dist(stopped, _pose(page)) < 0.02
    assert math.dist(start, stopped) > 0.3
    assert errors == []


def test_it_shows_the_camera_through_the_server(page, stack):
    login(page, stack, "vera", next_path="/drive/")
    camera = page.locator("#camera-img")
    page.wait_for_function("() => document.getElementById('camera-img').naturalWidth > 0", timeout=10_000)
    assert camera.get_attribute("src").startswith("/video/stream")
    expect(page.locator("#camera-placeholder")).to_be_hidden()
    expect(page.locator("#stick")).to_have_count(0)


def test_it_drives_with_the_on_screen_joystick(page, stack):
    login(page, stack, "olga", next_path="/drive/")
    _ready_to_drive(page, stack)
    expect(page.locator("#lock-state")).to_have_text("Nobody is driving")
    box = page.locator("#stick").bounding_box()
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(cx, cy)
    page.mouse.down()
    page.mouse.move(cx, cy - 60, steps=5)  # push the stick forward
    page.wait_for_function("() => Number(document.getElementById('cmd-vel').dataset.linear) > 0.2")
    expect(page.locator("#lock-state")).to_have_text("You are driving")
    page.mouse.up()
    expect(page.locator("#cmd-vel")).to_have_attribute("data-linear", "0")
