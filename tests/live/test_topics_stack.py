"""Watching any topic through real processes, scaled: two Daphne processes and a robot link on a
private Redis. Pages on both web processes share one upstream subscription; it goes after the
grace period once the last page on either has left."""

import asyncio
import json
import os
import shutil
import time
import urllib.request

import pytest
from websockets.asyncio.client import connect

from robot import interface as ri
from tests.stack import Stack
from tests.support_processes import PrivateRedis

SERVICES_PASS = bool(os.environ.get("REDIS_URL"))
TF = ri.topic("tf").name


def subscriptions(stack: Stack, topic: str) -> int:
    with urllib.request.urlopen(f"http://127.0.0.1:{stack.video_port}/sim/introspect", timeout=5) as res:
        return int(json.loads(res.read())["subscriptions"].get(topic, 0))


async def wait_for(predicate, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not await asyncio.to_thread(predicate):
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        await asyncio.sleep(0.1)


@pytest.mark.redis
@pytest.mark.skipif(not SERVICES_PASS or shutil.which("redis-server") is None, reason="runs in the services pass")
def test_pages_on_two_web_processes_share_one_upstream_subscription():
    redis = PrivateRedis().start()
    try:
        with Stack(redis_url=redis.url, webs=2, env={"TOPICS_IDLE_GRACE_S": "0.5"}) as stack:
            stack.wait_robot_online()
            cookie = stack.login_cookie("vera")

            async def scenario() -> None:
                sockets = [await connect(f"ws://127.0.0.1:{port}/ws/live/", origin=f"http://127.0.0.1:{port}",
                                         additional_headers={"Cookie": cookie}) for port in stack.web_ports * 2]
                for ws in sockets:
                    await ws.send(json.dumps({"action": "watch_topic", "topic": TF}))
                for ws in sockets:  # every page gets the topic's messages, whichever process serves it
                    deadline = time.monotonic() + 20
                    while True:
                        frame = json.loads(await asyncio.wait_for(ws.recv(), 20))
                        if any(u["key"] == f"topic:{TF}" for u in frame.get("updates") or ()):
                            break
                        assert time.monotonic() < deadline
                assert await asyncio.to_thread(subscriptions, stack, TF) == 1
                for ws in sockets[:3]:
                    await ws.close()
                await asyncio.sleep(2)  # past the grace period: the last page still holds it
                assert await asyncio.to_thread(subscriptions, stack, TF) == 1
                await sockets[3].close()
                await wait_for(lambda: subscriptions(stack, TF) == 0, 20, "the upstream unsubscribe")

            asyncio.run(scenario())
    finally:
        redis.stop()
