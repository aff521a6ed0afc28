"""Live updates through real processes: Daphne with the link inside (embedded), and two Daphne
processes fed from one Redis subscription each with the link in its own process (scaled)."""

import asyncio
import json
import os
import shutil
import subprocess
import time

import pytest
from websockets.asyncio.client import connect

from robot import interface as ri
from tests.stack import PASSWORD, Stack, free_port

KEYS = ["odom", "battery_soc", "rosout"]
# Each test starts its own processes: run each in one pass of the suite only.
SERVICES_PASS = bool(os.environ.get("REDIS_URL"))


async def watch(url: str, origin: str, cookie: str, count: int) -> list[dict]:
    """Open ``count`` live sockets on ``url`` and return each one's first frame carrying odom."""

    async def one() -> dict:
        async with connect(url, origin=origin, additional_headers={"Cookie": cookie}) as ws:
            first = json.loads(await ws.recv())
            assert first["kind"] == "status"
            await ws.send(json.dumps({"action": "watch", "keys": KEYS}))
            deadline = time.monotonic() + 15
            while time.monotonic() < deadline:
                frame = json.loads(await asyncio.wait_for(ws.recv(), 15))
                if frame["kind"] == "updates" and any(u["key"] == "odom" for u in frame["updates"]):
                    return frame
            raise AssertionError("no odom update arrived")

    return await asyncio.gather(*(one() for _ in range(count)))


def introspect(stack: Stack) -> dict:
    import urllib.request

    with urllib.request.urlopen(f"http://127.0.0.1:{stack.video_port}/sim/introspect", timeout=5) as res:
        return json.loads(res.read())


def viewer_cookie(stack: Stack) -> str:
    stack.manage("adduser", "vera", "--role", "viewer", "--password", PASSWORD)
    return stack.login_cookie("vera")


def check_frames(frames: list[dict]) -> None:
    for frame in frames:
        keys = [u["key"] for u in frame["updates"]]
        assert len(keys) == len(set(keys)) or "rosout" in keys  # latest wins: one odom per frame
        odom = next(u for u in frame["updates"] if u["key"] == "odom")
        assert set(odom) == {"key", "msg", "t"} and "pose" in odom["msg"]


@pytest.mark.skipif(SERVICES_PASS, reason="runs in the embedded pass")
def test_it_fans_out_embedded_through_a_real_daphne():
    with Stack(users=False) as stack:
        cookie = viewer_cookie(stack)
        stack.wait_robot_online()
        frames = asyncio.run(watch(f"ws://127.0.0.1:{stack.web_port}/ws/live/", stack.url, cookie, 30))
        check_frames(frames)
        assert introspect(stack)["subscriptions"][ri.topic("odom").name] == 1


@pytest.mark.redis
@pytest.mark.skipif(not SERVICES_PASS or shutil.which("redis-server") is None, reason="runs in the services pass")
def test_it_fans_out_scaled_through_one_redis_subscription_per_web_process():
    port = free_port()
    redis = subprocess.Popen(["redis-server", "--port", str(port), "--save", "", "--appendonly", "no"],
                             stdout=subprocess.DEVNULL, start_new_session=True)
    try:
        with Stack(redis_url=f"redis://127.0.0.1:{port}/0", webs=2, users=False) as stack:
            cookie = viewer_cookie(stack)
            stack.wait_robot_online()

            async def both() -> list[list[dict]]:
                return await asyncio.gather(*(watch(f"ws://127.0.0.1:{p}/ws/live/", f"http://127.0.0.1:{p}", cookie, 10)
                                              for p in stack.web_ports))

            for frames in asyncio.run(both()):
                check_frames(frames)
            sim = introspect(stack)
            assert sim["clients"] == 1 and sim["subscriptions"][ri.topic("odom").name] == 1
            channels = subprocess.run(["redis-cli", "-p", str(port), "pubsub", "numsub", "cyborg:live"],
                                      capture_output=True, text=True, check=True).stdout.split()
            assert channels == ["cyborg:live", "2"]  # one subscription per web process, not per socket
    finally:
        redis.terminate()
        redis.wait(5)
