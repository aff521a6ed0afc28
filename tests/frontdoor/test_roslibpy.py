"""The front door with unmodified roslibpy (and a raw websocket where a refusal's status frame is the
point) against the real product: Daphne with the link inside, driving the simulator."""

from __future__ import annotations

import json
import time
import urllib.error
import urllib.request
from collections.abc import Iterator

import pytest
import roslibpy
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from robot import interface as ri
from tests.helpers import wait_until
from tests.sim.support import Inbox
from tests.stack import PASSWORD, Stack

ODOM, BATTERY, CMD_VEL = ri.topic("odom").name, ri.topic("battery_soc").name, ri.topic("cmd_vel").name


def _post(stack: Stack, path: str, token: str = "", data: dict | None = None) -> dict:
    headers = {"Content-Type": "application/json"}
    if token:
        headers["Authorization"] = f"Token {token}"
    request = urllib.request.Request(f"{stack.url}{path}", data=json.dumps(data or {}).encode(), headers=headers)
    with urllib.request.urlopen(request, timeout=20) as res:
        return json.loads(res.read())


@pytest.fixture(scope="module")
def stack() -> Iterator[Stack]:
    with Stack(env={"TELEOP_DEADMAN_S": "0.5", "TOPICS_IDLE_GRACE_S": "0.5"}) as running:
        running.wait_robot_online(timeout=60)
        running.tokens = {name: _post(running, "/api/auth/token/", data={"username": name, "password": PASSWORD})
                          ["token"] for name in ("otto", "vera")}
        yield running


def ticket_url(stack: Stack, who: str) -> str:
    return _post(stack, "/api/frontdoor/ticket/", stack.tokens[who])["url"]


def ros_for(stack: Stack, who: str) -> roslibpy.Ros:
    ros = roslibpy.Ros(ticket_url(stack, who))
    ros.run(timeout=30)
    return ros


def received(stack: Stack, topic: str) -> list[dict]:
    with urllib.request.urlopen(f"http://127.0.0.1:{stack.video_port}/sim/received?topic={topic}&last=200",
                                timeout=10) as res:
        return json.loads(res.read())["messages"]


def subscriptions(stack: Stack, topic: str) -> int:
    with urllib.request.urlopen(f"http://127.0.0.1:{stack.video_port}/sim/introspect", timeout=10) as res:
        return int(json.loads(res.read())["subscriptions"].get(topic, 0))


def raw_frames(url: str, frames: list[dict], until: str, timeout: float = 20) -> list[dict]:
    """Send ``frames`` on a raw socket; return what came back until a frame containing ``until``."""
    seen: list[dict] = []
    with connect(url, open_timeout=20) as ws:
        for frame in frames:
            ws.send(json.dumps(frame))
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            text = ws.recv(timeout=deadline - time.monotonic())
            seen.append(json.loads(text))
            if until in text:
                return seen
    raise AssertionError(f"no frame with {until!r}: {seen[-5:]}")


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
            msg = odom.wait(lambda items: items[-1] if len(items) >= 3 else None, timeout=30, what="odometry")
            assert set(msg) >= {"header", "pose", "twist"} and "covariance" in msg["pose"]  # whole, not summarised
            battery.wait(timeout=30, what="battery")
            assert 0.0 <= battery.items[0]["data"] <= 1.0
        assert subscriptions(stack, ODOM) == 1
        topics = roslibpy.Service(clients[0], "/rosapi/topics", "rosapi/Topics").call(
            roslibpy.ServiceRequest({}), timeout=20)
        assert ODOM in topics["topics"] and BATTERY in topics["topics"]
        gaps = [b - a for a, b in zip(odoms[0].times, odoms[0].times[1:], strict=False)]
        assert sum(gaps) / len(gaps) >= 0.1  # its throttle_rate (200 ms) applied: far fewer than the 10+ Hz
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
    _post(stack, "/api/robot/estop/", stack.tokens["otto"])
    try:
        time.sleep(0.5)
        seen = raw_frames(ticket_url(stack, "otto"), [
            {"op": "publish", "topic": CMD_VEL, "msg": {"linear": {"x": 0.3}, "angular": {"z": 0.0}}},
        ], until="E-STOP")
        assert any(f.get("op") == "status" and f["level"] == "error" for f in seen)
        time.sleep(0.3)
        assert all(m["msg"]["linear"]["x"] == 0.0 for m in received(stack, CMD_VEL)[-5:])
    finally:
        _post(stack, "/api/robot/estop/release/", stack.tokens["otto"], {"confirm": True})


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
        _post(stack, "/api/frontdoor/ticket/")
    assert refused.value.code in (401, 403)
