"""Redis commands per teleop Twist: a driver holds a key on ``/ws/teleop/`` against the simulator
while MONITOR records every command the Redis server gets from a client (a script, EVALSHA, once).
Counted per Twist the robot received: all of them (the moving robot's topics stored and published
too), and those of the drive itself (everything but the latest-state store and the live feed).

Two wirings: scaled (Daphne and ``robotlink`` as separate processes sharing a private redis-server)
and embedded (one Daphne process, its private Valkey server). Prints ``name: value`` lines.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import glob
import json
import sys
import threading
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


LIVE = (":latest-state", ":live")  # the robot's topics stored and fanned out, whoever drives


class Monitor(threading.Thread):
    def __init__(self, url: str) -> None:
        super().__init__(daemon=True)
        self.url, self.commands, self.recording = url, [], False

    def run(self) -> None:
        with contextlib.suppress(redis.ConnectionError), redis.Redis.from_url(self.url).monitor() as monitor:
            for command in monitor.listen():  # until the server stops with its stack
                # A script's own commands are shown too: the script is the one round trip.
                if self.recording and command.get("client_type") != "lua":
                    self.commands.append(command["command"])


def kind(command: str) -> str:
    """``EVALSHA`` or ``RPUSH link-requests``: the command and the last part of its first argument."""
    name, _, rest = command.partition(" ")
    return f"{name} {rest.split(' ', 1)[0].rsplit(':', 1)[-1][:30]}"


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


def measure(stack: Stack, url: str) -> tuple[float, float]:
    cookie = stack.login_cookie("otto")
    monitor = Monitor(url)
    monitor.start()
    time.sleep(2)  # settle: the link subscribed, the first values stored
    sent = twists(stack)
    monitor.recording = True
    asyncio.run(drive(stack, cookie))
    monitor.recording = False
    moved = max(1, twists(stack) - sent)
    drive_only = [c for c in monitor.commands if not any(part in c for part in LIVE) and "INFO" not in c]
    # What the drive's commands are (on stderr): the command and its key's last part.
    kinds = collections.Counter(kind(c) for c in drive_only)
    print({kind: round(n / moved, 2) for kind, n in kinds.most_common(8)}, file=sys.stderr)
    return len(monitor.commands) / moved, len(drive_only) / moved


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
            scaled = measure(stack, server.url)
    finally:
        server.stop()
    print(f"redis_commands_per_twist_scaled: {scaled[0]:.2f}")
    print(f"redis_drive_commands_per_twist_scaled: {scaled[1]:.2f}")
    with Stack() as stack:
        stack.wait_robot_online()
        embedded = measure(stack, private_server_of(stack.procs[-1].pid))
    print(f"redis_commands_per_twist_embedded: {embedded[0]:.2f}")
    print(f"redis_drive_commands_per_twist_embedded: {embedded[1]:.2f}")


if __name__ == "__main__":
    main()
