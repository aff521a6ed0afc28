"""The front door's test stack (Daphne with the link inside, driving the simulator) and helpers."""

from __future__ import annotations

import json
import time
import urllib.request
from collections.abc import Iterator

import pytest
import roslibpy
from websockets.sync.client import connect

from tests.stack import PASSWORD, Stack


def post(stack: Stack, path: str, token: str = "", data: dict | None = None) -> dict:
    headers = {"Content-Type": "application/json"}
    if token:
        headers["Authorization"] = f"Token {token}"
    request = urllib.request.Request(f"{stack.url}{path}", data=json.dumps(data or {}).encode(), headers=headers)
    with urllib.request.urlopen(request, timeout=20) as res:
        return json.loads(res.read())


@pytest.fixture(scope="package")
def stack() -> Iterator[Stack]:
    with Stack(env={"TELEOP_DEADMAN_S": "0.5", "TOPICS_IDLE_GRACE_S": "0.5"}) as running:
        running.wait_robot_online(timeout=60)
        running.tokens = {name: post(running, "/api/auth/token/", data={"username": name, "password": PASSWORD})
                          ["token"] for name in ("otto", "vera")}
        yield running


def ticket_url(stack: Stack, who: str) -> str:
    return post(stack, "/api/frontdoor/ticket/", stack.tokens[who])["url"]


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


