"""What an admin sets in the admin pages (paces, the allowlist, sensitive topics) takes effect on tools
already connected, within about a second, as revocation does: unmodified roslibpy against the product."""

from __future__ import annotations

import http.cookiejar
import re
import time
import urllib.parse
import urllib.request

import roslibpy

from robot import interface as ri
from tests.frontdoor.conftest import received, ros_for
from tests.helpers import wait_until
from tests.sim.support import Inbox
from tests.stack import PASSWORD

ODOM, RECHARGE = ri.topic("odom").name, ri.topic("battery_recharge_state").name
BEACON = "/lab/live_beacon"


def admin_add(stack, model: str, fields: dict[str, str]) -> None:
    """Add a row through the admin's own form, signed in as the admin (ada)."""
    jar = http.cookiejar.CookieJar()
    opener = urllib.request.build_opener(urllib.request.HTTPCookieProcessor(jar))
    login = f"{stack.url}/accounts/login/"
    page = opener.open(login, timeout=20).read().decode()
    token = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', page).group(1)
    opener.open(urllib.request.Request(login, headers={"Referer": login}, data=urllib.parse.urlencode(
        {"username": "ada", "password": PASSWORD, "csrfmiddlewaretoken": token}).encode()), timeout=20).read()
    add = f"{stack.url}/admin/{model}/add/"
    page = opener.open(add, timeout=20).read().decode()
    token = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', page).group(1)
    with opener.open(urllib.request.Request(add, headers={"Referer": add}, data=urllib.parse.urlencode(
            {**fields, "csrfmiddlewaretoken": token, "_save": "Save"}).encode()), timeout=20) as res:
        assert res.url.rstrip("/").endswith(model), f"the admin did not save {fields}: {res.read().decode()[-2000:]}"


def mean_gap(inbox: Inbox, after: float) -> float:
    times = [t for t in list(inbox.times) if t >= after]
    assert len(times) >= 3, times
    return (times[-1] - times[0]) / (len(times) - 1)


def test_a_pace_set_in_the_admin_applies_to_a_tool_already_subscribed(stack):
    ros = ros_for(stack, "vera")
    try:
        odom = Inbox()
        roslibpy.Topic(ros, ODOM, "nav_msgs/Odometry").subscribe(odom)  # no throttle: the front door paces
        odom.wait(lambda items: len(items) >= 10, timeout=30, what="odometry at its default pace")
        assert mean_gap(odom, 0.0) < 0.2  # the default pace, 10 Hz
        admin_add(stack, "robot/frontdoorpace", {"topic": ODOM, "hz": "2"})
        changed = time.time()
        time.sleep(4.0)
        assert mean_gap(odom, changed + 1.5) > 0.4  # 2 Hz, from about a second after the admin saved it
    finally:
        ros.close()


def test_a_topic_marked_sensitive_in_the_admin_stops_reaching_a_viewer_already_subscribed(stack):
    viewer, operator = ros_for(stack, "vera"), ros_for(stack, "otto")
    try:
        seen, kept = Inbox(), Inbox()
        roslibpy.Topic(viewer, RECHARGE, "std_msgs/Int8").subscribe(seen)
        roslibpy.Topic(operator, RECHARGE, "std_msgs/Int8").subscribe(kept)
        seen.wait(lambda items: len(items) >= 2, timeout=30, what="the recharge state, before")
        admin_add(stack, "history/topicpolicy", {"topic": RECHARGE, "msg_type": "std_msgs/Int8", "mode": "off",
                                                 "sensitive": "on"})
        time.sleep(1.5)
        before, operator_before = len(seen), len(kept)
        time.sleep(3.0)
        assert len(seen) == before  # the viewer's subscription ended
        assert len(kept) >= operator_before + 2  # an operator's goes on
    finally:
        viewer.close()
        operator.close()


def test_a_topic_allowed_in_the_admin_may_be_published_by_a_tool_already_connected(stack):
    ros = ros_for(stack, "otto")
    try:
        beacon = roslibpy.Topic(ros, BEACON, "std_msgs/String")
        beacon.advertise()
        beacon.publish(roslibpy.Message({"data": "refused"}))
        time.sleep(1.0)
        assert not received(stack, BEACON)
        admin_add(stack, "robot/frontdoorallowance", {"kind": "topic", "name": BEACON})
        time.sleep(1.0)
        beacon.publish(roslibpy.Message({"data": "allowed"}))
        wait_until(lambda: received(stack, BEACON), timeout=10, what="the publish, once allowed")
        assert [m["msg"]["data"] for m in received(stack, BEACON)] == ["allowed"]
    finally:
        ros.close()
