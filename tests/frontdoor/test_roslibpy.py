"""The front door with unmodified roslibpy (and a raw websocket where a refusal's status frame is the
point) against the real product: Daphne with the link inside, driving the simulator."""

from __future__ import annotations

import time
import urllib.error

import pytest
import roslibpy
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from robot import interface as ri
from tests.frontdoor.conftest import post, raw_frames, received, ros_for, subscriptions, ticket_url
from tests.helpers import wait_until
from tests.sim.support import Inbox

ODOM, BATTERY, CMD_VEL = ri.topic("odom").name, ri.topic("battery_soc").name, ri.topic("cmd_vel").name


def test_a_viewer_subscribes_lists_topics_and_shares_one_upstream_subscription(stack):
    clients = [ros_for(stack, "vera") for _ in range(3)]
    try:
        odoms, batteries = [], []
        for ros in clients:
            odoms.append(Inbox())
            roslibpy.Topic(ros, ODOM, "nav_msgs/Odometry", throttle_rate=200).subscribe(odoms[-1])
            batteries.append(Inbox())
            roslibpy.Topic(ros, BATTERY, "std_msgs/Float32").subscribe(batteries[-1])
        for odom, battery in zip(odoms, batteries, strict=True):
            msg = odom.wait(lambda items: items[-1] if len(items) >= 5 else None, timeout=30, what="odometry")
            assert set(msg) >= {"header", "pose", "twist"} and "covariance" in msg["pose"]  # whole, not summarised
            battery.wait(timeout=30, what="battery")
            assert 0.0 <= battery.items[0]["data"] <= 1.0
        assert subscriptions(stack, ODOM) == 1
        topics = roslibpy.Service(clients[0], "/rosapi/topics", "rosapi/Topics").call(
            roslibpy.ServiceRequest({}), timeout=20)
        assert ODOM in topics["topics"] and BATTERY in topics["topics"]
        gaps = [b - a for a, b in zip(odoms[0].times, odoms[0].times[1:], strict=False)]
        # its throttle_rate (200 ms) applied: far fewer than the 10+ Hz (the first two may come together:
        # the stored message at once, then the newest)
        assert sum(gaps) / len(gaps) >= 0.1
    finally:
        for ros in clients:
            ros.close()


def test_a_viewer_may_not_publish_velocity(stack):
    before = len(received(stack, CMD_VEL))
    seen = raw_frames(ticket_url(stack, "vera"), [
        {"op": "advertise", "topic": CMD_VEL, "type": "geometry_msgs/Twist"},
        {"op": "publish", "topic": CMD_VEL, "msg": {"linear": {"x": 0.3}, "angular": {"z": 0.0}}, "id": "p1"},
    ], until="publish")
    assert any(f.get("op") == "status" and f["level"] == "error" and "viewers may not publish" in f["msg"]
               for f in seen)
    time.sleep(0.5)
    assert len(received(stack, CMD_VEL)) == before


def test_an_operator_drives_and_the_deadman_stops_the_robot_when_input_stops(stack):
    ros = ros_for(stack, "otto")
    try:
        cmd = roslibpy.Topic(ros, CMD_VEL, "geometry_msgs/Twist")
        cmd.advertise()
        for _ in range(10):
            cmd.publish(roslibpy.Message({"linear": {"x": 0.3, "y": 0, "z": 0}, "angular": {"x": 0, "y": 0, "z": 0}}))
            time.sleep(0.1)
        wait_until(lambda: any(m["msg"]["linear"]["x"] > 0.2 for m in received(stack, CMD_VEL)), timeout=20,
                   what="the robot commanded forward")
        # The tool stops sending (its page froze): the deadman publishes zero.
        wait_until(lambda: received(stack, CMD_VEL)[-1]["msg"]["linear"]["x"] == 0.0, timeout=20,
                   what="the deadman's zero")
        huge = {"linear": {"x": 50.0}, "angular": {"z": 0.0}}
        cmd.publish(roslibpy.Message(huge))
        time.sleep(0.3)
        assert max(m["msg"]["linear"]["x"] for m in received(stack, CMD_VEL)[-20:]) <= 0.5 + 1e-9  # the limits
    finally:
        ros.close()


def test_velocity_is_refused_while_the_estop_is_latched(stack):
    post(stack, "/api/robot/estop/", stack.tokens["otto"])
    try:
        time.sleep(0.5)
        seen = raw_frames(ticket_url(stack, "otto"), [
            {"op": "publish", "topic": CMD_VEL, "msg": {"linear": {"x": 0.3}, "angular": {"z": 0.0}}},
        ], until="E-STOP")
        assert any(f.get("op") == "status" and f["level"] == "error" for f in seen)
        time.sleep(0.3)
        assert all(m["msg"]["linear"]["x"] == 0.0 for m in received(stack, CMD_VEL)[-5:])
    finally:
        post(stack, "/api/robot/estop/release/", stack.tokens["otto"], {"confirm": True})


def test_a_ticket_works_once_and_nothing_else_gets_in(stack):
    url = ticket_url(stack, "vera")
    with connect(url, open_timeout=20):
        pass
    for bad in (url, url.split("?")[0], url[:-3] + "abc"):
        with pytest.raises(InvalidStatus) as refused:
            connect(bad, open_timeout=20)
        assert refused.value.response.status_code == 403
    with pytest.raises(InvalidStatus):  # a browser page elsewhere
        connect(ticket_url(stack, "vera"), origin="http://evil.example", open_timeout=20)


def test_a_ticket_needs_a_token_or_a_session(stack):
    with pytest.raises(urllib.error.HTTPError) as refused:
        post(stack, "/api/frontdoor/ticket/")
    assert refused.value.code in (401, 403)


def test_a_later_tool_gets_the_latched_map_at_once_from_the_one_upstream_subscription(stack):
    topic = ri.topic("map").name
    first, second = ros_for(stack, "vera"), ros_for(stack, "vera")
    try:
        maps = Inbox()
        roslibpy.Topic(first, topic, "nav_msgs/OccupancyGrid").subscribe(maps)
        maps.wait(timeout=30, what="the map, first tool")
        grid = maps.items[0]
        assert len(grid["data"]) == grid["info"]["width"] * grid["info"]["height"] > 0  # whole, not summarised
        later = Inbox()
        roslibpy.Topic(second, topic, "nav_msgs/OccupancyGrid").subscribe(later)
        later.wait(timeout=10, what="the map, second tool")
        assert later.items[0] == grid
        assert subscriptions(stack, topic) == 1
    finally:
        first.close()
        second.close()
