"""The map page in a real browser: press-drag-release sends a goal and the robot marker moves to it."""

import math
import re

import pytest
from playwright.sync_api import expect

from tests.browser.support import login

pytestmark = pytest.mark.browser


def robot_xy(page) -> tuple[float, float]:
    view = page.locator("#map-view")
    return float(view.get_attribute("data-robot-x")), float(view.get_attribute("data-robot-y"))


def open_map(page, stack, user: str) -> None:
    login(page, stack, user, next_path="/map/")
    expect(page.locator("#map-view")).to_have_attribute("data-ready", "1")
    expect(page.locator("#map-view")).to_have_attribute("data-robot-x", re.compile(r"^-?\d"))


def test_it_sends_a_goal_by_dragging_and_the_robot_marker_moves_there(page, stack):
    open_map(page, stack, "otto")
    start = robot_xy(page)
    # The session's robot may be anywhere another test left it: aim at least 3 m away.
    goal = max([(3.5, -1.0), (-3.5, -1.0)], key=lambda g: math.dist(g, start))
    page.click('[data-mode="goal"]')
    sx, sy = page.evaluate("([x, y]) => window.cyborgMap.toClient(x, y)", list(goal))
    hx, hy = page.evaluate("([x, y]) => window.cyborgMap.toClient(x, y)", [goal[0], goal[1] + 1.0])
    page.mouse.move(sx, sy)
    page.mouse.down()
    page.mouse.move(hx, hy, steps=5)
    page.mouse.up()
    expect(page.locator("#goal-status")).to_have_text("active", timeout=10_000)
    sent = stack_goal(page)
    assert math.hypot(sent["x"] - goal[0], sent["y"] - goal[1]) < 0.1
    assert abs(sent["yaw"] - math.pi / 2) < 0.1  # dragged straight up the map
    first = math.dist(start, goal)
    page.wait_for_function(
        """([gx, gy, d]) => {
            const v = document.getElementById('map-view').dataset;
            return Math.hypot(v.robotX - gx, v.robotY - gy) < d;
        }""", arg=[goal[0], goal[1], first - 1.0], timeout=20_000)
    expect(page.locator("#goal-status")).to_have_text("succeeded", timeout=20_000)
    assert math.dist(robot_xy(page), goal) < 0.3


def stack_goal(page) -> dict:
    return page.evaluate("() => window.cyborgMap.state.goal")


def test_it_zooms_with_the_wheel_and_shows_map_coordinates(page, stack):
    open_map(page, stack, "vera")
    expect(page.locator('[data-mode="goal"]')).to_be_disabled()
    before = page.evaluate("() => window.cyborgMap.view.scale")
    cx, cy = page.evaluate("() => window.cyborgMap.toClient(0, 0)")
    page.mouse.move(cx, cy)
    page.mouse.wheel(0, -400)
    page.wait_for_function("(s) => window.cyborgMap.view.scale > s * 1.5", arg=before)
    # Zooming around the cursor keeps the point under it.
    after = page.evaluate("() => window.cyborgMap.toClient(0, 0)")
    assert math.dist(after, (cx, cy)) < 2
    expect(page.locator("#map-cursor")).to_have_text("x 0.00 m · y 0.00 m")


PINCH = """([ax, ay, bx, by, spread]) => {
    const el = document.getElementById('map-overlay');
    const fire = (type, id, x, y) => el.dispatchEvent(new PointerEvent(type, {
        pointerId: id, pointerType: 'touch', isPrimary: id === 11, clientX: x, clientY: y, bubbles: true}));
    fire('pointerdown', 11, ax, ay); fire('pointerdown', 12, bx, by);
    for (let k = 1; k <= 5; k++) {
        fire('pointermove', 11, ax - spread * k / 5, ay); fire('pointermove', 12, bx + spread * k / 5, by);
    }
    fire('pointerup', 11, ax - spread, ay); fire('pointerup', 12, bx + spread, by);
}"""


def test_it_fits_a_phone_and_zooms_with_a_pinch(browser, stack):
    context = browser.new_context(viewport={"width": 390, "height": 844}, is_mobile=True, has_touch=True)
    page = context.new_page()
    try:
        open_map(page, stack, "vera")
        overflow = page.evaluate("document.documentElement.scrollWidth - window.innerWidth")
        assert overflow <= 0, f"the map page is {overflow}px wider than a phone screen"
        before = page.evaluate("() => window.cyborgMap.view.scale")
        cx, cy = page.evaluate("() => window.cyborgMap.toClient(0, 0)")
        page.evaluate(PINCH, [cx - 20, cy, cx + 20, cy, 40])
        # Fingers 40 px apart spread to 120 px: three times the zoom, centred between them.
        assert page.evaluate("() => window.cyborgMap.view.scale") == pytest.approx(before * 3, rel=0.01)
        assert math.dist(page.evaluate("() => window.cyborgMap.toClient(0, 0)"), (cx, cy)) < 2
    finally:
        context.close()


def test_a_location_saved_on_one_page_appears_on_every_other_at_once(browser, page, stack):
    watcher_context = browser.new_context(viewport={"width": 1280, "height": 900})
    watcher = watcher_context.new_page()
    try:
        open_map(watcher, stack, "vera")
        open_map(page, stack, "otto")
        page.fill("#save-pose-name", "browser-porch")
        page.click("#save-pose-form button[type=submit]")
        # No reload on the watcher's side: the change arrives on its live socket.
        expect(watcher.locator('#location-list li[data-location="browser-porch"]')).to_be_visible()
        expect(watcher.locator("#send-to option", has_text="browser-porch")).to_have_count(1)
        page.once("dialog", lambda dialog: dialog.accept())
        page.click('#location-list li[data-location="browser-porch"] button[aria-label="Delete browser-porch"]')
        expect(watcher.locator('#location-list li[data-location="browser-porch"]')).to_have_count(0)
    finally:
        watcher_context.close()


def test_an_active_goal_shows_distance_and_time_left_and_its_cancel_says_where_not_its_id(page, stack):
    open_map(page, stack, "otto")
    start = robot_xy(page)
    goal = max([(3.5, -1.0), (-3.5, -1.0)], key=lambda g: math.dist(g, start))
    token = next(c["value"] for c in page.context.cookies() if c["name"] == "csrftoken")
    sent = page.request.post(f"{stack.url}/api/navigation/goal/", data={"x": goal[0], "y": goal[1], "yaw": 0},
                             headers={"X-CSRFToken": token})
    assert sent.ok, sent.text()
    left = page.locator("#goal-left")
    expect(left).to_have_text(re.compile(r"^\d+(\.\d)? m to go · about \d+ (s|min)$"), timeout=15_000)
    metres = float(left.inner_text().split()[0])
    assert metres <= math.dist(start, goal) + 0.5, (metres, start, goal)

    page.click("#goal-cancel")
    toast = page.locator("#notices .notice").last
    expect(toast).to_contain_text(f"Cancelling the goal to ({goal[0]:.2f}, {goal[1]:.2f})")
    assert "cyborg_commander-" not in toast.inner_text()
    expect(page.locator("#goal-status")).to_have_text(re.compile("cancelled|aborted|succeeded"), timeout=15_000)
    expect(left).to_have_text("—")


def test_a_goal_another_tool_sent_is_shown_as_such_and_its_cancel_stops_it(page, stack):
    import roslibpy

    from robot import interface as ri

    open_map(page, stack, "otto")
    start = robot_xy(page)
    goal = max([(3.5, -1.0), (-3.5, -1.0)], key=lambda g: math.dist(g, start))
    tool = roslibpy.Ros("127.0.0.1", stack.sim_port)
    tool.run(timeout=10)
    try:
        name, msg_type = ri.action_topic("move_base", "goal", ri.ROS1)
        target = {"position": {"x": goal[0], "y": goal[1], "z": 0.0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1.0}}
        roslibpy.Topic(tool, name, msg_type).publish(roslibpy.Message({
            "header": {"frame_id": ri.MAP_FRAME}, "goal_id": {"stamp": {"secs": 0, "nsecs": 0}, "id": "rviz-browser"},
            "goal": {"target_pose": {"header": {"frame_id": ri.MAP_FRAME}, "pose": target}}}))
        expect(page.locator("#goal-status")).to_have_text("active", timeout=15_000)
        expect(page.locator("#goal-target")).to_have_text("sent by another tool")
        expect(page.locator("#map-view")).to_have_attribute("data-goal-foreign", "1")
        page.click("#goal-cancel")
        expect(page.locator("#notices .notice").last).to_contain_text("Cancelling the goal another tool sent")
        expect(page.locator("#goal-status")).to_have_text("cancelled", timeout=15_000)
    finally:
        tool.close()
