"""The whole product on the ROS 2 simulator (``make run ROS=2``): the Connection card names the ROS."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.browser.support import fresh_page, login
from tests.stack import Stack

pytestmark = pytest.mark.browser


def test_the_connection_card_says_the_robot_runs_ros_2(browser):
    with Stack(sim_args=("--ros", "2", "--startup-s", "0.5")) as stack:
        stack.wait_robot_online(timeout=120)
        with fresh_page(browser, viewport={"width": 1366, "height": 800}) as page:
            login(page, stack, "vera")
            expect(page.locator('#card-connection [data-field="link.state"]')).to_have_text("Robot online",
                                                                                            timeout=30_000)
            expect(page.locator('#card-connection [data-field="link.ros"]')).to_have_text("ROS 2", timeout=30_000)
