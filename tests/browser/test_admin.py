"""The admin at a laptop's width: the recording-policy list fits, and the favicon exists."""

from __future__ import annotations

import pytest

from tests.browser.support import DESKTOP, login

pytestmark = pytest.mark.browser

SEED = """
from history.models import TopicPolicy
for name, msg_type in (("/cyborg_controller/emotional_controller_status", "std_msgs/Bool"),
                       ("/move_base/global_costmap/costmap_updates", "map_msgs/OccupancyGridUpdate"),
                       ("/controller_viewer/smach/container_structure", "smach_msgs/SmachContainerStructure")):
    TopicPolicy.objects.update_or_create(topic=name, defaults={"msg_type": msg_type, "mode": "off",
                                                               "interval_s": 12.5, "retention_s": 7776000})
"""


def test_the_policy_list_fits_a_1366_px_screen_and_the_favicon_is_served(browser, stack):
    stack.manage("shell", "-c", SEED)
    context = browser.new_context(viewport=DESKTOP)
    page = context.new_page()
    page.set_default_timeout(15_000)
    try:
        login(page, stack, "ada", next_path="/admin/history/topicpolicy/")
        results = page.locator("#changelist .results")
        fit = results.evaluate("el => [el.scrollWidth, el.clientWidth]")
        assert fit[0] <= fit[1], f"the list scrolls inside its box: {fit}"
        for header in ("Topic", "Mode", "Interval", "Retention"):
            box = page.locator("#result_list thead th", has_text=header).bounding_box()
            assert box is not None and box["x"] + box["width"] <= DESKTOP["width"], header
        assert page.evaluate("document.documentElement.scrollWidth <= window.innerWidth")

        icon = page.goto(f"{stack.url}/favicon.ico")
        assert icon is not None and icon.ok, icon and icon.status
        assert icon.headers["content-type"].startswith("image/svg+xml")
    finally:
        context.close()
