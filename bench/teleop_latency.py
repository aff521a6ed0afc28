"""Teleop latency through the real product: key press → first Twist at the simulator,
release → zero Twist, websocket disconnect → zero Twist.

Starts the stack (simulator + Daphne, embedded default), logs in as an operator over HTTP,
drives over ``/ws/teleop/`` and reads the simulator's receive times (wall clock, same
machine) from its ``/sim/received`` introspection endpoint. Prints ``name: value`` lines.
"""

from __future__ import annotations

import asyncio
import json
import statistics
import sys
import time
import urllib.parse
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from websockets.asyncio.client import ClientConnection, connect  # noqa: E402

from tests.stack import Stack  # noqa: E402

PRESSES = 40
DISCONNECTS = 15
WAIT_S = 3.0
POLL_S = 0.01
FORWARD = {"type": "input", "linear": 1.0, "angular": 0.0}


def login(stack: Stack, username: str) -> str:
    """Log in through the form like a browser; return the Cookie header."""
    return stack.login_cookie(username)


class Simulator:
    """The simulator's record of every Twist it received, with its wall-clock receive time."""

    def __init__(self, video_port: int, topic: str) -> None:
        self.url = f"http://127.0.0.1:{video_port}/sim/received?topic={urllib.parse.quote(topic)}"

    def _get(self, last: int) -> dict:
        with urllib.request.urlopen(f"{self.url}&last={last}", timeout=5) as res:
            return json.loads(res.read())

    def count(self) -> int:
        return self._get(0)["count"]

    def first_after(self, before: int, predicate) -> float:
        """Receive time of the first Twist after index ``before`` that matches.

        The simulator stamps each message as it arrives, so polling slower costs no accuracy;
        polling faster would only load the simulator's loop and delay what we measure.
        """
        deadline = time.monotonic() + WAIT_S
        while time.monotonic() < deadline:
            time.sleep(POLL_S)
            data = self._get(0)
            if data["count"] > before:
                messages = self._get(data["count"] - before)["messages"]
                hits = [m["t"] for m in messages if predicate(m["msg"])]
                if hits:
                    return hits[0]
        raise SystemExit("the simulator never received the expected Twist")


def moving(msg: dict) -> bool:
    return msg["linear"]["x"] != 0


def zero(msg: dict) -> bool:
    return msg["linear"]["x"] == 0 and msg["angular"]["z"] == 0


async def open_socket(stack: Stack, cookie: str) -> ClientConnection:
    ws = await connect(f"ws://127.0.0.1:{stack.web_port}/ws/teleop/", origin=stack.url,
                       additional_headers={"Cookie": cookie}, compression=None)
    assert json.loads(await ws.recv())["type"] == "lock"
    return ws


async def timed(ws_action, sim: Simulator, predicate) -> float:
    before = sim.count()
    sent = time.time()
    await ws_action()
    received = await asyncio.to_thread(sim.first_after, before, predicate)
    return (received - sent) * 1000


async def run(stack: Stack) -> dict[str, list[float]]:
    cookie = login(stack, "otto")
    sim = Simulator(stack.video_port, "/cmd_vel")
    results: dict[str, list[float]] = {"press": [], "release": [], "disconnect": []}
    ws = await open_socket(stack, cookie)
    for i in range(PRESSES + 1):
        press = await timed(lambda: ws.send(json.dumps(FORWARD)), sim, moving)
        release = await timed(lambda: ws.send(json.dumps({"type": "release"})), sim, zero)
        if i:  # the first press also takes the drive lock (and writes its audit entry)
            results["press"].append(press)
            results["release"].append(release)
    await ws.close()
    for _ in range(DISCONNECTS):
        ws = await open_socket(stack, cookie)
        await timed(lambda ws=ws: ws.send(json.dumps(FORWARD)), sim, moving)
        results["disconnect"].append(await timed(ws.close, sim, zero))
    return results


def p(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def main() -> None:
    with Stack() as stack:
        stack.wait_robot_online()
        results = asyncio.run(run(stack))
    for name, values in results.items():
        print(f"{name}_p50_ms: {statistics.median(values):.1f}")
        print(f"{name}_p99_ms: {p(values, 0.99):.1f}")
        print(f"{name}_samples: {len(values)}")


if __name__ == "__main__":
    main()
