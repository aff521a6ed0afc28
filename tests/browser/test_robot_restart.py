"""The robot goes away and comes back (the simulator process is stopped and started again)
while the Drive page and the dashboard are open, at a desktop and a phone width."""

from __future__ import annotations

import re

import pytest
from playwright.sync_api import expect

from tests.browser.support import PHONE, WIDTHS, login

pytestmark = pytest.mark.browser


def test_a_robot_restart_greys_the_camera_disables_driving_and_leaves_no_stale_state(browser, stack):
    contexts, drives, dashboards = [], [], []
    try:
        for viewport in WIDTHS.values():
            phone = viewport is PHONE
            context = browser.new_context(viewport=viewport, is_mobile=phone, has_touch=phone)
            contexts.append(context)
            drive = context.new_page()
            login(drive, stack, "otto", next_path="/drive/")
            dashboard = context.new_page()
            dashboard.goto(f"{stack.url}/")
            drives.append(drive)
            dashboards.append(dashboard)
        for drive in drives:
            expect(drive.locator("#camera")).to_have_attribute("data-state", "live", timeout=15_000)
            expect(drive.locator("#camera-age")).to_have_text(re.compile(r"^frame \d+\.\d s old$"))
            expect(drive.locator("#lock-acquire")).to_be_visible()
            expect(drive.locator("#drive-offline")).to_be_hidden()

        # The robot in demo before it restarts: afterwards nothing may still say so.
        dashboards[0].click('#card-mode [data-mode="demo"]')
        for dashboard in dashboards:
            expect(dashboard.locator('#card-mode [data-field="mode.reached"]')).to_contain_text("demo", timeout=15_000)
        stack.stop_sim()
        try:
            for drive in drives:
                # Driving is off at once; the picture greys out 2 s after its last frame.
                expect(drive.locator("#drive-offline")).to_be_visible(timeout=10_000)
                expect(drive.locator("#lock-acquire")).to_be_hidden()
                expect(drive.locator("#camera")).to_have_attribute("data-state", "stale", timeout=10_000)
                expect(drive.locator("#camera-placeholder")).to_be_visible()
                expect(drive.locator("#camera-placeholder")).to_contain_text("Camera unavailable")
                # Said once: no server placeholder picture under the page's own words.
                expect(drive.locator("#camera-img")).to_be_hidden(timeout=10_000)
                expect(drive.locator("#camera-age")).to_contain_text(re.compile("last frame|no frame"))
                # Greyed out only once the last frame is 2 s old.
                said = drive.locator("#camera-age").inner_text()
                age = re.match(r"last frame (\d+) s ago", said)
                assert "just now" not in said and (age is None or int(age[1]) >= 2), said
            desk = drives[0]
            desk.locator("#drive h2").click()
            desk.keyboard.down("w")
            desk.wait_for_timeout(300)
            desk.keyboard.up("w")
            expect(desk.locator("#lock-state")).not_to_have_text("You are driving")
            expect(desk.locator("#cmd-vel")).to_have_attribute("data-linear", "0")
            # A command while the robot is away fails, and says so.
            dashboard = dashboards[0]
            dashboard.click('#card-mode [data-mode="stop"]')
            expect(dashboard.locator('#card-mode [data-field="mode.request"]')).to_contain_text("failed")
        finally:
            stack.start_sim()
            stack.wait_robot_online()

        for dashboard in dashboards:
            # Back in startup (which lasts 15 s before its first transition): the cards say so at once.
            expect(dashboard.locator('#card-mode [data-field="mode.reached"]')).to_have_text("startup", timeout=5_000)
            expect(dashboard.locator('[data-field="smach.current"]')).to_have_text("startup", timeout=5_000)
        for drive in drives:
            expect(drive.locator("#drive-offline")).to_be_hidden(timeout=15_000)
            expect(drive.locator("#lock-acquire")).to_be_visible()
            expect(drive.locator("#camera")).to_have_attribute("data-state", "live", timeout=20_000)
            expect(drive.locator("#camera-placeholder")).to_be_hidden()
        for dashboard in dashboards:
            # The failure from before the restart is gone, and the headline agrees with "Active".
            expect(dashboard.locator('#card-mode [data-field="mode.request"]')).to_have_text("—", timeout=10_000)
            active = dashboard.locator('[data-field="smach.active"]')
            expect(active).not_to_have_text("—", timeout=10_000)
            dashboard.wait_for_function("""() => {
                const chain = document.querySelector('[data-field="smach.active"]').textContent.split(' › ');
                return document.querySelector('[data-field="smach.current"]').textContent === chain[chain.length - 1];
            }""")
            expect(dashboard.locator('.alert[data-alert="offline"]')).to_have_count(0)
        # The link's reconnect left no backoff timer behind to fire on the open connection.
        assert "can't connect in this state" not in stack.log("web")
        # Leave the shared robot where the other tests expect it: out of startup, in suspension.
        dashboards[0].click('#card-mode [data-mode="stop"]')
        for dashboard in dashboards:
            expect(dashboard.locator('[data-field="smach.current"]')).to_have_text("suspension", timeout=25_000)
    finally:
        for context in contexts:
            context.close()
