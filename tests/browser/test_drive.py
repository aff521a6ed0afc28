"""Drive the simulated robot from the manual control page in a real browser."""

import math

import pytest
from playwright.sync_api import expect

from tests.browser.support import fresh_page, login
from tests.browser.test_alerts import Robot
from tests.helpers import wait_until
from tests.support_processes import Client, received

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


def _cmd_vel_count(stack) -> int:
    return len(received(stack))


def _moving_twists_since(stack, start: int) -> list[dict]:
    msgs = [m["msg"] for m in received(stack)[start:]]
    return [t for t in msgs if t["linear"]["x"] != 0 or t["angular"]["z"] != 0]


def _stick_top(page) -> float:
    return page.evaluate("() => { const r = document.getElementById('stick').getBoundingClientRect();"
                         " return r.top + window.scrollY; }")


class _Hand:
    """Real input on the stick: the mouse on a desktop, a finger (touch events) on a phone."""

    def __init__(self, page) -> None:
        self.page = page
        self.touch = page.width_name == "phone"
        self.cdp = page.context.new_cdp_session(page) if self.touch else None

    def push(self, x: float, y: float, dx: float, dy: float) -> None:
        if self.touch:
            self.cdp.send("Input.dispatchTouchEvent", {"type": "touchStart", "touchPoints": [{"x": x, "y": y}]})
            for i in range(1, 7):
                point = {"x": x + dx * i / 6, "y": y + dy * i / 6}
                self.cdp.send("Input.dispatchTouchEvent", {"type": "touchMove", "touchPoints": [point]})
        else:
            self.page.mouse.move(x, y)
            self.page.mouse.down()
            self.page.mouse.move(x + dx, y + dy, steps=6)

    def let_go(self) -> None:
        if self.touch:
            self.cdp.send("Input.dispatchTouchEvent", {"type": "touchEnd", "touchPoints": []})
        else:
            self.page.mouse.up()


def _push_and_read(page, stack, hand: _Hand, dx: float, dy: float, until) -> list[dict]:
    """Push the stick from its visible centre by (dx, dy) px; the Twists the robot got meanwhile."""
    box = page.locator("#stick").bounding_box()
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    start = _cmd_vel_count(stack)
    hand.push(cx, cy, dx, dy)
    try:
        wait_until(lambda: any(until(t) for t in _moving_twists_since(stack, start)), timeout=10,
                   what="a Twist from the push at the robot")
    finally:
        hand.let_go()
    expect(page.locator("#cmd-vel")).to_have_attribute("data-linear", "0")
    # The stop at the robot too: on a loaded machine this push's last Twists may still be on their way,
    # and the next push must not count them as its own.
    wait_until(lambda: (msgs := received(stack)[start:]) and not _moving_twists_since(stack, start + len(msgs) - 1),
               what="the stop at the robot")
    return _moving_twists_since(stack, start)


def test_the_stick_pushed_up_drives_forward_after_an_alert_shifts_it(sized_page, stack):
    page = sized_page
    login(page, stack, "olga", next_path="/drive/")
    _ready_to_drive(page, stack)
    expect(page.locator("#lock-state")).to_have_text("Nobody is driving")
    expect(page.locator("#stick .front")).to_be_attached()
    page.locator("#stick").scroll_into_view_if_needed()
    before = _stick_top(page)

    robot = Robot(stack)
    try:
        robot.publish("bumper_state", {"front_bumpers": [True, False], "rear_bumpers": [False]})
        bumper = page.locator('#alert-strip [data-alert-key="bumper"]')
        expect(bumper).to_be_visible()
        page.wait_for_function("(before) => { const r = document.getElementById('stick').getBoundingClientRect();"
                               " return r.top + window.scrollY - before > 30; }", arg=before)
        page.locator("#stick").scroll_into_view_if_needed()
        hand = _Hand(page)

        # A gentle push up (less than the shift): forward, not reverse, and no turn.
        up = _push_and_read(page, stack, hand, 0, -30, lambda t: t["linear"]["x"] != 0)
        assert all(t["linear"]["x"] > 0 for t in up), up
        assert all(abs(t["angular"]["z"]) < 0.05 for t in up), up
        # Left and right turn on the spot: no reverse speed creeps in.
        for dx, sign in ((-50, 1), (50, -1)):
            turn = _push_and_read(page, stack, hand, dx, 0, lambda t: t["angular"]["z"] != 0)
            assert all(t["angular"]["z"] * sign > 0 for t in turn), turn
            assert all(abs(t["linear"]["x"]) < 0.02 for t in turn), turn
    finally:
        robot.close()
        # The bumper alert is shared by every page of the session's stack: acknowledge it.
        bumper.locator(".strip-ack").click()
        expect(bumper).to_have_count(0)


def test_the_sticks_knob_stands_out_from_its_ring(sized_page, stack):
    page = sized_page
    login(page, stack, "olga", next_path="/drive/")
    for theme in ("light", "dark"):
        page.evaluate("(t) => document.documentElement.dataset.theme = t", theme)
        colours = page.evaluate("""() => {
            const s = (sel) => getComputedStyle(document.querySelector('#stick ' + sel));
            return {front: s('.front').backgroundColor, back: s('.back').backgroundColor,
                    ring: s('.back').borderTopColor, opacity: s('.front').opacity};
        }""")
        assert colours["front"] != colours["back"], (theme, colours)
        assert colours["front"] != colours["ring"], (theme, colours)
        assert float(colours["opacity"]) == 1, (theme, colours)


def _press_goal(page, x: float, y: float) -> None:
    sx, sy = page.evaluate("([x, y]) => window.cyborgMap.toClient(x, y)", [x, y])
    page.mouse.move(sx, sy)
    page.mouse.down()
    page.mouse.up()


def test_after_an_estop_release_the_motors_off_refuse_moves_and_goals_with_the_reason(page, stack):
    login(page, stack, "otto", next_path="/drive/")
    _ready_to_drive(page, stack)
    expect(page.locator("#motors")).to_have_text("enabled")
    expect(page.locator("#motors-off")).to_be_hidden()
    client = Client(stack, "otto")
    try:
        assert client.post("/api/robot/estop/")[0] == 200
        assert client.post("/api/robot/estop/release/", {"confirm": True})[0] == 200
        expect(page.locator("#motors")).to_have_text("disabled")
        expect(page.locator("#motors-off")).to_be_visible()
        expect(page.locator("#motors-off")).to_contain_text("Motors off")
        start = _cmd_vel_count(stack)

        page.locator("#drive h2").click()  # the keys
        page.keyboard.down("w")
        expect(page.locator("#notices")).to_contain_text("Motors off: driving is refused")
        page.keyboard.up("w")
        page.evaluate("() => document.getElementById('notices').replaceChildren()")
        box = page.locator("#stick").bounding_box()  # the stick
        cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        page.mouse.move(cx, cy)
        page.mouse.down()
        page.mouse.move(cx, cy - 50, steps=5)
        expect(page.locator("#notices")).to_contain_text("Motors off: driving is refused")
        page.mouse.up()
        assert _moving_twists_since(stack, start) == []

        page.goto(f"{stack.url}/map/")  # a goal
        expect(page.locator("#map-view")).to_have_attribute("data-ready", "1")
        expect(page.locator("#goal-motors-off")).to_be_visible()
        before = page.evaluate("() => window.cyborgMap.state.goal?.id ?? null")
        page.click('button[data-mode="goal"]')
        _press_goal(page, 1.0, -2.0)
        expect(page.locator("#map-message")).to_contain_text("Motors off: a navigation goal is refused")
        expect(page.locator("#map-message")).to_be_in_viewport()
        assert page.evaluate("() => window.cyborgMap.state.goal?.id ?? null") == before

        page.click("#goal-motors-enable")  # Enable, beside the goal controls
        expect(page.locator("#goal-motors-off")).to_be_hidden()
    finally:
        client.post("/api/robot/estop/release/", {"confirm": True})
        client.post("/api/robot/motors/", {"enabled": True})


def test_a_driver_sees_who_took_over(browser, stack):
    with fresh_page(browser, viewport={"width": 1366, "height": 800}) as olga, \
            fresh_page(browser, viewport={"width": 1366, "height": 800}) as ada:
        login(olga, stack, "olga", next_path="/drive/")
        login(ada, stack, "ada", next_path="/drive/")
        _ready_to_drive(olga, stack)
        olga.click("#lock-acquire")
        expect(olga.locator("#lock-state")).to_have_text("You are driving")
        expect(ada.locator("#lock-state")).to_have_text("olga is driving")
        ada.once("dialog", lambda dialog: dialog.accept())
        ada.click("#lock-takeover")
        expect(ada.locator("#lock-state")).to_have_text("You are driving")
        expect(olga.locator("#notices")).to_contain_text("ada took over driving")
        ada.click("#lock-release")


def test_a_goal_pressed_off_the_map_says_so_on_the_map_and_the_next_press_aims_again(page, stack):
    login(page, stack, "otto", next_path="/map/")
    _ready_to_drive(page, stack)
    expect(page.locator("#map-view")).to_have_attribute("data-ready", "1")
    page.click("#zoom-out")
    page.click("#zoom-out")  # room around the map
    page.click('button[data-mode="goal"]')
    _press_goal(page, -13.0, 0.0)
    message = page.locator("#map-message")
    expect(message).to_contain_text("off the map")
    expect(message).to_be_in_viewport()
    expect(page.locator('button[data-mode="goal"]')).to_have_attribute("aria-pressed", "true")
    _press_goal(page, 1.0, -2.0)  # still aiming: this press sends the goal
    page.wait_for_function("() => Math.abs((window.cyborgMap.state.goal?.x ?? 99) - 1.0) < 0.1")
    expect(message).to_be_hidden()
    page.click("#goal-cancel")
