"""The E-STOP in a real browser: on every page, at phone and laptop widths, the button is
what a finger at its centre hits (toasts, joystick, header and banner never cover it), it is
at least 44x44 px, and tapping it latches the stop; every open page shows the banner, the
driver's page stops driving and says why, Esc engages it, and only a confirmed release clears it."""

import pytest
from playwright.sync_api import expect

from tests.browser.support import login

pytestmark = pytest.mark.browser
PAGES = ["/", "/map/", "/drive/", "/history/", "/activity/"]
VIEWPORTS = [{"width": 390, "height": 844}, {"width": 1366, "height": 800}]


def _post(page, stack, path: str, body: dict | None = None):
    token = next(c["value"] for c in page.context.cookies() if c["name"] == "csrftoken")
    return page.request.post(f"{stack.url}{path}", data=body or {}, headers={"X-CSRFToken": token})


def _latched(page, stack) -> bool:
    return page.request.get(f"{stack.url}/api/robot/estop/").json()["latched"]


def _release(page, stack) -> None:
    assert _post(page, stack, "/api/robot/estop/release/", {"confirm": True}).ok
    assert _post(page, stack, "/api/robot/motors/", {"enabled": True}).ok  # others share the robot


def _crowd_the_button(page, path: str) -> None:
    """Everything that could cover it: toasts, the joystick knob held down, the page scrolled."""
    page.evaluate("""async () => {
        const { notify } = await import('/static/js/notices.js');
        for (let i = 0; i < 6; i++) notify('A long notice that could cover the emergency stop button ' + i, 'error');
    }""")
    if path == "/drive/":
        zone = page.locator("#stick").bounding_box()
        page.mouse.move(zone["x"] + zone["width"] / 2, zone["y"] + zone["height"] / 2)
        page.mouse.down()
        page.mouse.move(zone["x"] + zone["width"] / 2 + 30, zone["y"] + zone["height"] / 2 - 60)
    page.evaluate("() => window.scrollTo(0, document.body.scrollHeight)")


@pytest.mark.parametrize("viewport", VIEWPORTS, ids=lambda v: f"{v['width']}x{v['height']}")
def test_the_button_is_never_covered_and_tapping_it_latches(browser, stack, viewport):
    context = browser.new_context(viewport=viewport, has_touch=viewport["width"] < 600)
    page = context.new_page()
    page.set_default_timeout(15_000)
    try:
        login(page, stack, "otto")
        for path in PAGES:
            page.goto(f"{stack.url}{path}")
            button = page.locator("#estop-btn")
            expect(button).to_be_visible()
            _crowd_the_button(page, path)
            box = button.bounding_box()
            assert box["width"] >= 44 and box["height"] >= 44, (path, box)
            assert box["x"] >= 0 and box["y"] >= 0 and box["x"] + box["width"] <= viewport["width"], (path, box)
            assert box["y"] + box["height"] <= viewport["height"], (path, box)
            on_top = page.evaluate("""() => {
                const b = document.getElementById('estop-btn').getBoundingClientRect();
                const hit = document.elementFromPoint(b.left + b.width / 2, b.top + b.height / 2);
                return hit === document.getElementById('estop-btn');
            }""")
            assert on_top, f"something covers the E-STOP on {path} at {viewport}"
            if path == "/drive/":
                page.mouse.up()
            if viewport["width"] < 600:
                button.tap()
            else:
                button.click()
            banner = page.locator("#estop-banner")
            expect(banner).to_be_visible()
            expect(banner).to_contain_text("E-STOP engaged by otto at ")
            assert _latched(page, stack), path
            # The banner never covers the button either.
            assert page.evaluate("""() => { const b = document.getElementById('estop-btn').getBoundingClientRect();
                return document.elementFromPoint(b.left + b.width / 2, b.top + b.height / 2).id === 'estop-btn'; }""")
            _release(page, stack)
    finally:
        if _latched(page, stack):
            _release(page, stack)
        context.close()


def test_every_open_page_sees_it_and_the_driver_stops(browser, stack):
    driver_context = browser.new_context(viewport={"width": 1280, "height": 900})
    watcher_context = browser.new_context(viewport={"width": 1280, "height": 900})
    driver, watcher = driver_context.new_page(), watcher_context.new_page()
    try:
        login(driver, stack, "otto", next_path="/drive/")
        login(watcher, stack, "vera", next_path="/activity/")
        assert _post(driver, stack, "/api/robot/motors/", {"enabled": True}).ok
        driver.locator("#drive h2").click()
        driver.keyboard.down("w")
        expect(driver.locator("#lock-state")).to_have_text("You are driving")

        watcher.keyboard.press("Escape")  # a viewer's shortcut does nothing but say so
        expect(watcher.locator("#notices")).to_contain_text("Only operators and admins")
        assert not _latched(driver, stack)

        driver.keyboard.press("Escape")  # the documented shortcut, while W is still held
        for page in (driver, watcher):
            expect(page.locator("#estop-banner")).to_be_visible()
            expect(page.locator("#estop-banner")).to_contain_text("E-STOP engaged by otto at ")
        expect(driver.locator("#lock-state")).to_contain_text("Stopped: E-STOP engaged by otto")
        expect(driver.locator("#cmd-vel")).to_have_attribute("data-linear", "0")
        expect(watcher.locator("#estop-release")).to_have_count(0)  # viewers cannot release
        driver.keyboard.up("w")

        # A page opened while latched shows it from the start.
        watcher.goto(f"{stack.url}/")
        expect(watcher.locator("#estop-banner")).to_be_visible()

        # Release needs a confirmation: dismissing it keeps the latch.
        driver.once("dialog", lambda dialog: dialog.dismiss())
        driver.locator("#estop-release").click()
        driver.wait_for_timeout(300)
        assert _latched(driver, stack)
        driver.once("dialog", lambda dialog: dialog.accept())
        driver.locator("#estop-release").click()
        for page in (driver, watcher):
            expect(page.locator("#estop-banner")).to_be_hidden()
        expect(driver.locator("#lock-state")).to_have_text("Nobody is driving")
    finally:
        if _latched(driver, stack):
            _release(driver, stack)
        else:
            _post(driver, stack, "/api/robot/motors/", {"enabled": True})
        driver_context.close()
        watcher_context.close()
