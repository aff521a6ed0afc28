"""Redis commands per teleop Twist: a driver holds a key on ``/ws/teleop/`` against the simulator,
and the Redis server's INFO commandstats count what the product sent meanwhile, less what it sends
as much while nobody drives (the link storing the robot's topics, heartbeats).

Two wirings: scaled (Daphne and ``robotlink`` as separate processes sharing a private redis-server)
and embedded (one Daphne process, its private Valkey server). Prints ``name: value`` lines.
"""

from __future__ import annotations

import asyncio
import glob
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import redis  # noqa: E402
from websockets.asyncio.client import connect  # noqa: E402

from tests.stack import Stack  # noqa: E402
from tests.support_processes import PrivateRedis  # noqa: E402

HOLD_S = 5.0
FORWARD = {"type": "input", "linear": 1.0, "angular": 0.0}
SEND_EVERY_S = 0.05  # the page repeats the held key's input


def commands(client: redis.Redis) -> int:
    stats = client.info("commandstats")
    return sum(int(v["calls"]) for k, v in stats.items() if k not in ("cmdstat_info",))


def twists(stack: Stack) -> int:
    import urllib.request

    url = f"http://127.0.0.1:{stack.video_port}/sim/received?topic=/cmd_vel&last=0"
    with urllib.request.urlopen(url, timeout=5) as res:
        return int(json.loads(res.read())["count"])


async def drive(stack: Stack, cookie: str) -> None:
    async with connect(f"ws://127.0.0.1:{stack.web_port}/ws/teleop/", origin=stack.url,
                       additional_headers={"Cookie": cookie}, compression=None) as ws:
        assert json.loads(await ws.recv())["type"] == "lock"
        end = time.monotonic() + HOLD_S
        while time.monotonic() < end:
            await ws.send(json.dumps(FORWARD))
            await asyncio.sleep(SEND_EVERY_S)
        await ws.send(json.dumps({"type": "release"}))
        await asyncio.sleep(0.5)


def measure(stack: Stack, client: redis.Redis) -> float:
    cookie = stack.login_cookie("otto")
    time.sleep(2)  # settle: the link subscribed, the first values stored
    before = commands(client)
    time.sleep(HOLD_S + 0.5)
    idle = commands(client) - before - 1  # this INFO call counts too
    before, sent = commands(client), twists(stack)
    asyncio.run(drive(stack, cookie))
    driven = commands(client) - before - 1
    moved = twists(stack) - sent
    return max(0, driven - idle) / max(1, moved)


def private_server_of(pid: int) -> str:
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        found = glob.glob(f"/tmp/cyborg-valkey-{pid}-*/valkey.sock")
        if found:
            return f"unix://{found[0]}"
        time.sleep(0.1)
    raise SystemExit(f"no private Valkey server of process {pid}")


def main() -> None:
    server = PrivateRedis().start()
    try:
        with Stack(redis_url=server.url) as stack:
            stack.wait_robot_online()
            scaled = measure(stack, redis.Redis.from_url(server.url))
    finally:
        server.stop()
    print(f"redis_commands_per_twist_scaled: {scaled:.2f}")
    with Stack() as stack:
        stack.wait_robot_online()
        client = redis.Redis.from_url(private_server_of(stack.procs[-1].pid))
        embedded = measure(stack, client)
    print(f"redis_commands_per_twist_embedded: {embedded:.2f}")


if __name__ == "__main__":
    main()
