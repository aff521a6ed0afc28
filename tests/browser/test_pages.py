"""Every page in a real browser, at a desktop and a phone width: one live socket, no errors,
navigation to every page, nothing wider than the screen, no control under another element
(a notice showing included), a compact header on a phone. The admin pages operators use and
the API docs get the same layout and navigation checks. On every page, at rest at its top and its
bottom, the E-STOP is on screen, what a tap at its centre hits, and on or beside no control."""

from __future__ import annotations

import contextlib
import re

import pytest
from playwright.sync_api import TimeoutError as PlaywrightTimeout
from playwright.sync_api import expect

from tests.browser.checks import COVERED_CONTROLS, ESTOP_CLEAR, HORIZONTAL_OVERFLOW
from tests.browser.support import PHONE, fresh_page, login

pytestmark = pytest.mark.browser

# Our pages that must be in the navigation; every page the navigation links to is checked (a page
# added to it later is covered without a change here).
PAGES = {"/": "Dashboard", "/map/": "Map", "/drive/": "Drive", "/topics/": "Topics",
         "/statemachine/": "State machine", "/diagnostics/": "Diagnostics", "/history/": "History",
         "/activity/": "Activity"}
# Ours but reached from the History page rather than the navigation.
HISTORY_PAGES = ("/history/replay/", "/history/incidents/")
# Linked from every page's navigation but not ours: the API's Swagger UI and Django's admin.
OTHER_PAGES = {"/api/docs/": "API", "/admin/": "Admin"}
# The pages of those that operators use, each with the navigation entry it belongs to; they get the
# same layout and navigation checks as ours.
THEIR_PAGES = {
    "/api/docs/": "API",
    "/admin/": "Admin",
    "/admin/robot/location/": "Admin",
    "/admin/robot/location/add/": "Admin",
    "/admin/history/topicpolicy/": "Admin",
}
# A row in each list (the stack starts with none), removed afterwards; an incident with a long summary
# (it names an option of Replay's incident list and a row of the Incidents table).
SEED_ROWS = """
import time
from history.models import Incident, TopicPolicy
from robot.models import Location
Incident.objects.update_or_create(by="layout_check", defaults={"kind": "manual", "t": time.time() - 60,
    "start": time.time() - 120, "end": time.time() - 30, "complete": True, "driver": "a_driver_with_a_long_name",
    "summary": "the robot stopped in the doorway of the east wing while a trolley passed, and then turned round"})
Location.objects.update_or_create(name="layout_check_desk", defaults={"x": 1.5, "y": -2.25, "yaw": 1.2,
                                  "description": "a place with a long description to fill the row"})
TopicPolicy.objects.update_or_create(topic="/layout_check/a_rather_long_topic_name/with_parts",
                                     defaults={"msg_type": "std_msgs/String", "mode": "off"})
"""
DROP_ROWS = """
from history.models import Incident, TopicPolicy
from robot.models import Location
Incident.objects.filter(by="layout_check").delete()
Location.objects.filter(name="layout_check_desk").delete()
TopicPolicy.objects.filter(topic__startswith="/layout_check/").delete()
"""

# Records the URL of every websocket the document opens.
COUNT_SOCKETS = """(() => {
    const Original = window.WebSocket;
    window.openedSockets = [];
    window.WebSocket = class extends Original {
        constructor(url, ...rest) { super(url, ...rest); window.openedSockets.push(String(url)); }
    };
})()"""
SHOW_NOTICE = """async () => {
    const src = [...document.scripts].find((s) => s.src.includes('/js/header.js')).src;
    const { notify } = await import(src.replace('header.js', 'notices.js'));
    notify('A long notice that must cover no control, card heading or the emergency stop', 'error', {timeout: 0});
}"""
LONG_TOPIC = """() => {
    const name = '/cyborg_navigation/move_base/global_costmap/obstacle_layer/parameter_descriptions';
    document.getElementById('topic').add(new Option(name, name, true, true));
}"""


def nav_links(page) -> dict[str, str]:
    return dict(page.eval_on_selector_all(
        ".mainnav a", "links => links.map(a => [new URL(a.href).pathname, a.textContent.trim()])"))


def our_pages(page, stack) -> dict[str, str]:
    """Every page of ours the dashboard's navigation links to (the admin's and the API docs' are not ours)."""
    page.goto(f"{stack.url}/")
    linked = nav_links(page)
    assert PAGES.items() <= linked.items() and OTHER_PAGES.items() <= linked.items(), linked
    return {path: name for path, name in linked.items() if path not in OTHER_PAGES}


def settle(page, path: str) -> None:
    """Let a page draw what it fetches: until the network is quiet, or a moment for a page that
    never lets it be (the drive page's camera stream, a page that polls)."""
    page.wait_for_timeout(300)
    if path != "/drive/":
        with contextlib.suppress(PlaywrightTimeout):
            page.wait_for_load_state("networkidle", timeout=3000)


def test_every_page_runs_without_errors_on_one_live_socket(sized_page, stack):
    page = sized_page
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(f"{page.url}: {exc}"))
    page.add_init_script(COUNT_SOCKETS)
    login(page, stack, "ada")
    for path in our_pages(page, stack):
        page.goto(f"{stack.url}{path}")
        expect(page.locator("#link-pill")).to_have_text("robot online")
        assert page.evaluate("() => 'cyborgLive' in window") is False
        sockets = page.evaluate("() => window.openedSockets")
        assert [url for url in sockets if url.endswith("/ws/live/")] == [sockets[0]], (path, sockets)
    assert errors == []


def test_every_page_fits_the_screen_and_no_control_is_covered_even_by_a_notice(sized_page, stack, rows):
    page = sized_page
    login(page, stack, "ada")
    for path in [*our_pages(page, stack), *HISTORY_PAGES, "/accounts/login/"]:
        if path == "/accounts/login/":
            page.context.clear_cookies()
        page.goto(f"{stack.url}{path}")
        settle(page, path)
        if path != "/accounts/login/":
            expect(page.locator("#link-pill")).to_have_text("robot online")
            page.evaluate(SHOW_NOTICE)
            expect(page.locator("#notices .notice-error")).to_be_visible()
        assert page.evaluate(HORIZONTAL_OVERFLOW) <= 0, f"{path} scrolls sideways at {page.viewport['width']} px"
        assert page.evaluate(COVERED_CONTROLS) == [], path


@pytest.fixture
def rows(stack):
    stack.manage("shell", "-c", SEED_ROWS)
    yield
    stack.manage("shell", "-c", DROP_ROWS)


def open_their_page(page, stack, path: str) -> None:
    page.goto(f"{stack.url}{path}")
    if path == "/api/docs/":
        expect(page.locator(".swagger-ui .opblock").first).to_be_visible()  # Swagger UI has drawn the API
    else:
        expect(page.locator("#content")).to_be_visible()
    settle(page, path)


def test_the_admin_pages_and_the_api_docs_fit_the_screen_and_no_control_is_covered(sized_page, stack, rows):
    page = sized_page
    login(page, stack, "ada")
    for path in THEIR_PAGES:
        open_their_page(page, stack, path)
        if path.endswith("/location/") or path.endswith("/topicpolicy/"):
            expect(page.locator("#result_list tbody tr").first).to_be_visible()
            # The whole list in view, not scrolled inside its box (every column on a laptop's screen).
            fit = page.locator("#changelist .results").evaluate("el => el.scrollWidth - el.clientWidth")
            assert page.viewport is PHONE or fit <= 0, f"{path}: the list scrolls {fit} px inside its box"
        if path.startswith("/admin/robot/location/"):  # headings in degrees, as on the map page
            expect(page.locator("#content")).to_contain_text("Heading (°)")
        if path == "/admin/robot/location/":
            expect(page.locator("#result_list tbody tr", has_text="layout_check_desk")).to_contain_text("69")
        assert page.evaluate(HORIZONTAL_OVERFLOW) <= 0, f"{path} scrolls sideways at {page.viewport['width']} px"
        assert page.evaluate(COVERED_CONTROLS) == [], path


def test_every_page_reaches_every_page_from_its_navigation(sized_page, stack):
    page = sized_page
    phone = page.viewport is PHONE
    login(page, stack, "ada")
    ours = our_pages(page, stack)
    expected = nav_links(page)
    paths = list(ours)
    for i, path in enumerate(paths):
        page.goto(f"{stack.url}{path}")
        assert nav_links(page) == expected, path
        expect(page.locator(".mainnav a[aria-current=page]")).to_have_count(1)
        expect(page.locator(".mainnav a[aria-current=page]")).to_have_text(ours[path])
        header = page.locator(".topbar").bounding_box()
        if phone:
            # The header is one compact row; the pages are one tap away behind the menu.
            assert header["height"] <= 60, f"the header takes {header['height']} px on {path}"
            expect(page.locator(".mainnav")).to_be_hidden()
            expect(page.locator("#menu-btn .menu-current")).to_have_text(ours[path])  # where you are
            page.click("#menu-btn")
        expect(page.locator("#estop-btn")).to_be_visible()
        target = paths[(i + 1) % len(paths)]
        page.click(f'.mainnav a[href="{target}"]')
        page.wait_for_url(f"{stack.url}{target}")
    # The pages that are not ours have the same navigation, their own entry marked, and it works.
    for i, path in enumerate(THEIR_PAGES):
        open_their_page(page, stack, path)
        assert nav_links(page) == expected, path
        expect(page.locator(".mainnav a[aria-current=page]")).to_have_count(1)
        expect(page.locator(".mainnav a[aria-current=page]")).to_have_text(THEIR_PAGES[path])
        target = paths[i % len(paths)]
        link = page.locator(f'.mainnav a[href="{target}"]')
        expect(link).to_be_visible()
        link.click()
        page.wait_for_url(f"{stack.url}{target}")


def test_the_header_menu_opens_and_closes_on_a_phone(browser, stack):
    with fresh_page(browser, viewport=PHONE, is_mobile=True, has_touch=True) as page:
        login(page, stack, "vera")
        page.click("#menu-btn")
        expect(page.locator("#menu-btn")).to_have_attribute("aria-expanded", "true")
        expect(page.locator(".mainnav a", has_text="Activity")).to_be_visible()
        expect(page.locator(".who")).to_contain_text("vera")
        page.click("#menu-btn")
        expect(page.locator(".mainnav")).to_be_hidden()
        expect(page.locator("#menu-btn")).to_contain_text(re.compile("Dashboard"))


def test_the_estop_is_on_every_page_on_screen_clickable_and_clear_of_every_control(sized_page, stack, rows):
    page = sized_page
    login(page, stack, "ada")
    for path in [*our_pages(page, stack), *HISTORY_PAGES, *THEIR_PAGES]:
        if path in THEIR_PAGES:
            open_their_page(page, stack, path)
        else:
            page.goto(f"{stack.url}{path}")
            settle(page, path)
        if path == "/history/":  # a recorded topic with a long name in the Topic list
            page.evaluate(LONG_TOPIC)
        assert page.evaluate(HORIZONTAL_OVERFLOW) <= 0, f"{path} scrolls sideways at {page.viewport['width']} px"
        assert page.evaluate(ESTOP_CLEAR) == [], path
        assert "{#" not in page.locator("body").inner_text(), f"{path} shows a template comment"


def test_the_alerts_page_shows_its_history_first_and_its_settings_at_a_readable_width(browser, stack):
    with fresh_page(browser, viewport={"width": 1366, "height": 800}) as page:
        login(page, stack, "olga", next_path="/alerts/")
        history = page.locator("#alert-history").bounding_box()
        assert history["y"] < 800, f"the alert history starts at {history['y']} px, below the first screen"
        main = page.locator("main.page").bounding_box()
        settings = page.locator("#alert-delivery").bounding_box()
        # A form reads at about 40 characters' width and more; a quarter of a laptop's screen squeezes it.
        assert settings["width"] >= 0.4 * main["width"], (settings["width"], main["width"])
        assert page.locator("#alert-history-card").bounding_box()["width"] >= 0.95 * main["width"] - 40
