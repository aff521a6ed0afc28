"""What the header pill and the dashboard's Connection card say, on a stack of this module's own:
the same words for a robot frozen with SIGSTOP; after a robot's return the E-STOP banner no longer
says its steps failed because it was offline (the latch stays until released); and when the web
server itself is gone, "server unreachable", not a robot link down."""

from __future__ import annotations

import os
import signal

import pytest
from playwright.sync_api import expect

from tests.browser.support import fresh_page, login
from tests.stack import Stack
from tests.support_processes import Client

pytestmark = pytest.mark.browser


@pytest.fixture(scope="module")
def own_stack():
    with Stack() as running:
        running.wait_robot_online(timeout=120)
        yield running


def _pill(page):
    return page.locator("#link-pill")


def _card(page):
    return page.locator('#card-connection [data-field="link.state"]')


def test_a_frozen_robot_reads_the_same_in_the_pill_and_the_card(browser, own_stack):
    with fresh_page(browser, viewport={"width": 1366, "height": 800}) as page:
        login(page, own_stack, "vera")
        expect(_pill(page)).to_have_text("robot online", timeout=30_000)
        expect(_card(page)).to_have_text("Robot online")
        os.kill(own_stack.sim_proc.pid, signal.SIGSTOP)
        try:
            expect(_pill(page)).to_have_text("not responding", timeout=30_000)
            expect(_card(page)).to_have_text("Not responding")
        finally:
            os.kill(own_stack.sim_proc.pid, signal.SIGCONT)
        expect(_pill(page)).to_have_text("robot online", timeout=30_000)
        expect(_card(page)).to_have_text("Robot online")


def test_the_estop_banner_drops_offline_failures_once_the_robot_is_back_and_stays_latched(browser, own_stack):
    otto = Client(own_stack, "otto")
    with fresh_page(browser, viewport={"width": 1366, "height": 800}) as page:
        login(page, own_stack, "otto")
        own_stack.stop_sim()
        try:
            expect(_pill(page)).to_have_text("robot offline", timeout=30_000)
            page.locator("#estop-btn").click()
            failed = page.locator("#estop-banner-failed")
            expect(failed).to_contain_text("Robot offline", timeout=30_000)
        finally:
            own_stack.start_sim()
        expect(_pill(page)).to_have_text("robot online", timeout=60_000)
        expect(failed).not_to_contain_text("Failed:", timeout=30_000)
        expect(failed).to_contain_text("robot is back")
        expect(page.locator("#estop-banner")).to_be_visible()
        assert otto.get("/api/robot/estop/")[1]["latched"]  # only a person releases it

        page.locator("#estop-btn").click()  # pressed again, the steps now reach the robot
        expect(failed).to_have_text("", timeout=30_000)
        assert otto.post("/api/robot/estop/release/", {"confirm": True})[0] == 200
        assert otto.post("/api/robot/motors/", {"enabled": True})[0] == 200


def test_a_server_gone_reads_server_unreachable_not_link_down(browser, own_stack):
    with fresh_page(browser, viewport={"width": 1366, "height": 800}) as page:
        login(page, own_stack, "vera")
        expect(_pill(page)).to_have_text("robot online", timeout=30_000)
        own_stack._terminate(own_stack.web)
        expect(_pill(page)).to_have_text("server unreachable", timeout=30_000)
        expect(_card(page)).to_have_text("Server unreachable")
