"""Alerts on every page, in a real browser against a simulator process: each kind injected as the
robot would send it (a ROS node over rosbridge, unmodified roslibpy), seen on Drive and Map at once;
acknowledged on one page and gone from the other; the robot frozen with SIGSTOP and shown "not
responding" within 3 s; start times that survive a reload; the battery in every header."""

from __future__ import annotations

import os
import signal
import time

import pytest
import roslibpy
from playwright.sync_api import expect

from robot import interface as ri
from tests.browser.support import fresh_page, login
from tests.stack import Stack
from tests.support_processes import Client

pytestmark = pytest.mark.browser

PAGES = ("/drive/", "/map/")


@pytest.fixture(scope="module")
def low_stack():
    with Stack(sim_args=("--battery-soc", "0.08")) as running:
        running.wait_robot_online()
        yield running


class Robot:
    """A ROS node of the robot's, as rosbridge sees it."""

    def __init__(self, stack: Stack) -> None:
        self.ros = roslibpy.Ros("127.0.0.1", stack.sim_port)
        self.ros.run(timeout=10)
        self.topics: dict[str, roslibpy.Topic] = {}

    def publish(self, key: str, msg: dict) -> None:
        t = ri.topic(key)
        if key not in self.topics:
            self.topics[key] = roslibpy.Topic(self.ros, t.name, t.type)
            self.topics[key].advertise()
            time.sleep(0.3)
        self.topics[key].publish(roslibpy.Message(msg))

    def close(self) -> None:
        self.ros.close()


def strip(page):
    return page.locator("#alert-strip")


def alert(page, key: str):
    return page.locator(f'#alert-strip [data-alert-key="{key}"]')


def test_every_kind_of_alert_shows_on_drive_and_map_at_once(browser, low_stack):
    robot = Robot(low_stack)
    with fresh_page(browser, viewport={"width": 1366, "height": 800}) as drive, \
            fresh_page(browser, viewport={"width": 390, "height": 844}, is_mobile=True, has_touch=True) as map_page:
        login(drive, low_stack, "olga", next_path="/drive/")
        login(map_page, low_stack, "vera", next_path="/map/")
        pages = (drive, map_page)
        for page in pages:
            expect(alert(page, "battery_low")).to_contain_text("Battery low: 8 %", timeout=15_000)
            expect(page.locator("#header-battery")).to_have_attribute("aria-label", "Battery 8 %")
            expect(page.locator("#header-battery")).to_have_class("pill battery-pill pill-bad")

        robot.publish("rosout", {"level": 16, "name": "/move_base", "msg": "planner crashed",
                                 "header": {"stamp": {"secs": int(time.time()), "nsecs": 0}}})
        robot.publish("diagnostics", {"header": {}, "status": [
            {"level": 2, "name": "Test: Injected", "message": "overheating", "hardware_id": "t", "values": []}]})
        robot.publish("bumper_state", {"front_bumpers": [True, False], "rear_bumpers": [False]})
        status, _ = Client(low_stack, "otto").post("/api/robot/estop/")
        assert status == 200
        for page in pages:
            expect(page.locator(".strip-more")).to_be_visible()  # more than three: the rest behind a button
            page.locator(".strip-more").click()
        for page in pages:
            expect(alert(page, "log:/move_base")).to_contain_text("FATAL from /move_base: planner crashed")
            expect(alert(page, "log:/move_base")).to_have_class("strip-alert strip-critical")
            expect(alert(page, "diag:Test: Injected")).to_contain_text("Test: Injected: ERROR · overheating")
            expect(alert(page, "bumper")).to_contain_text("Bumper pressed: front")
            expect(alert(page, "estop")).to_contain_text("E-STOP engaged by otto")

        # A component no longer heard of turns STALE (after STALE_AFTER_S) on every page.
        for page in pages:
            expect(alert(page, "diag:Test: Injected")).to_contain_text("STALE", timeout=20_000)

        # The operator acknowledges the FATAL line on Drive: gone from Map too; a viewer has no button.
        expect(alert(map_page, "log:/move_base").locator(".strip-ack")).to_have_count(0)
        alert(drive, "log:/move_base").locator(".strip-ack").click()
        expect(alert(map_page, "log:/move_base")).to_have_count(0)
        status, _ = Client(low_stack, "otto").post("/api/robot/estop/release/", {"confirm": True})
        assert status == 200
        expect(alert(map_page, "estop")).to_have_count(0)

        # When it began survives a reload.
        began = alert(drive, "battery_low").locator("time").get_attribute("datetime")
        drive.reload()
        expect(alert(drive, "battery_low").locator("time")).to_have_attribute("datetime", began)

        # The robot frozen: "not responding" on both pages within 3 s, and an alert; then it answers again.
        os.kill(low_stack.sim_proc.pid, signal.SIGSTOP)
        frozen = time.monotonic()
        try:
            for page in pages:
                expect(page.locator("#link-pill")).to_have_text("not responding", timeout=5_000)
            assert time.monotonic() - frozen < 3.5
            for page in pages:
                expect(alert(page, "not_responding")).to_contain_text("not responding")
            # Drive offers no control of a robot that does not answer, and says why.
            expect(drive.locator("#drive-offline")).to_contain_text("not responding")
            expect(drive.locator("#lock-acquire")).to_be_hidden()
        finally:
            os.kill(low_stack.sim_proc.pid, signal.SIGCONT)
        for page in pages:
            expect(page.locator("#link-pill")).to_have_text("robot online", timeout=10_000)
            expect(alert(page, "not_responding")).to_have_count(0)

        # The robot gone: offline on every page.
        robot.close()
        low_stack.stop_sim()
        for page in pages:
            expect(alert(page, "offline")).to_contain_text("Robot offline", timeout=10_000)
