"""The E-STOP with Redis stopped, frozen and just restarted, for real (a private redis-server): the
robot gets a zero Twist within 500 ms of every press, the answer comes within a second and says
which steps were done, and the link holds the latch until Redis returns and keeps it there."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import time

import pytest
from django.conf import settings
from websockets.asyncio.client import connect

from robot import interface as ri
from tests.helpers import wait_until
from tests.stack import Stack
from tests.support_processes import Client, PrivateRedis, online, received

pytestmark = [pytest.mark.redis, pytest.mark.skipif(settings.EMBEDDED, reason="scaled wiring: services pass")]


def _zero_after(stack: Stack, pressed: float) -> float | None:
    zero = [m["t"] for m in received(stack) if m["t"] >= pressed and ri.is_zero_twist(m["msg"])]
    return zero[0] - pressed if zero else None


def _press(stack: Stack, page: Client) -> tuple[int, dict, float]:
    pressed = time.time()
    status, body = page.post("/api/robot/estop/", timeout=5)
    answered = time.time() - pressed
    wait_until(lambda: _zero_after(stack, pressed) is not None, timeout=3, what="a zero Twist at the robot")
    zero_s = _zero_after(stack, pressed)
    assert zero_s is not None and zero_s <= 0.5, zero_s
    assert answered <= 1.0, (answered, body)
    return status, body, answered


@pytest.fixture
def scaled():
    redis = PrivateRedis().start()
    stack = Stack(redis_url=redis.url)
    stack.redis = redis
    try:
        with online(stack):
            yield stack
    finally:
        redis.stop()


def test_estop_with_redis_stopped_then_restarted(scaled):
    page = Client(scaled, "otto")
    scaled.redis.stop()
    time.sleep(3)  # past the link's lease
    status, body, _ = _press(scaled, page)
    done = {s["step"]: s["ok"] for s in body["steps"]}
    assert done["zero_velocity"] and done["cancel_navigation"] and done["disable_motors"], body
    assert status == 502 and body["code"] == "partial", body  # the Redis steps say they were not done
    scaled.redis.start()
    wait_until(lambda: page.get("/api/robot/estop/")[1].get("latched") is True, timeout=10,
               what="the link writing its latch back")
    status, body = page.post("/api/robot/speech/", {"text": "hi"})
    assert status == 200


def test_estop_with_redis_frozen(scaled):
    page = Client(scaled, "otto")
    assert page.post("/api/robot/estop/")[0] == 200  # the store holds a released latch, older than the press
    assert page.post("/api/robot/estop/release/", {"confirm": True})[0] == 200
    os.kill(scaled.redis.proc.pid, signal.SIGSTOP)
    try:
        time.sleep(3)
        _press(scaled, page)
    finally:
        os.kill(scaled.redis.proc.pid, signal.SIGCONT)
    wait_until(lambda: page.get("/api/robot/estop/")[1].get("latched") is True, timeout=10,
               what="the link writing the press the store missed")
    assert page.get("/api/robot/estop/")[1]["by"] == "otto"
    status, body = page.get("/api/audit/?action=estop&limit=5")
    assert status == 200 and len(body["results"]) == 2, body  # both presses audited


async def _services_seen(ws, want: str | None, timeout: float) -> dict:
    """Status frames on a page's live socket until one says ``want`` is down (None: nothing is)."""
    async with asyncio.timeout(timeout):
        while True:
            frame = json.loads(await ws.recv())
            if frame.get("kind") != "status":
                continue
            down = frame.get("services_down") or {}
            if (want in down) if want else not down:
                return down


async def test_open_pages_say_when_redis_is_down_and_that_the_estop_still_works(scaled):
    page = await asyncio.to_thread(Client, scaled, "otto")
    async with connect(f"ws://127.0.0.1:{scaled.web_port}/ws/live/", origin=scaled.url,
                       additional_headers={"Cookie": page.cookie}) as ws:
        assert await _services_seen(ws, None, 5) == {}
        scaled.redis.stop()
        down = await _services_seen(ws, "redis", 5)
        assert "commands are refused" in down["redis"], down
        scaled.redis.start()
        await _services_seen(ws, None, 10)


def test_while_the_active_link_is_dead_the_standby_stops_the_robot(scaled):
    page = Client(scaled, "otto")
    active = scaled.link_proc
    standby = scaled.start_link()
    wait_until(lambda: "standby, waiting for the lease" in scaled.log("link"), timeout=30, what="the second link")
    time.sleep(2)  # its own rosbridge connection is up
    os.killpg(active.pid, signal.SIGKILL)
    _, body, _ = _press(scaled, page)  # long before the standby holds the lease
    zero = next(s for s in body["steps"] if s["step"] == "zero_velocity")
    assert zero["ok"] and "standby" in zero["detail"], body
    assert standby.poll() is None
