"""Live monitoring latency through the real product: simulator publish → browser websocket frame.

Starts the stack (simulator at 10 Hz pose rate + Daphne, embedded default), logs in once over
HTTP and opens N websockets on ``/ws/live/`` watching ``odom``. The simulator stamps each
``/odom`` header with its wall clock as it publishes; latency is the wall time a client read the
frame minus that stamp (same machine, same clock). Also reads the simulator's introspection to
show the server holds one upstream subscription per topic however many browsers watch.

Usage: ``.venv/bin/python bench/live_latency.py [clients]`` (default 50). Prints ``name: value``.
"""

from __future__ import annotations

import asyncio
import json
import logging
import sys
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from teleop_latency import login  # noqa: E402
from websockets.asyncio.client import connect  # noqa: E402

from robot import interface as ri  # noqa: E402
from tests.stack import Stack  # noqa: E402

log = logging.getLogger("bench.live_latency")

CLIENTS = 50
POSE_RATE_HZ = 10
WARMUP_S = 1.5  # after every client watches: the snapshot replay and connection churn settle
MEASURE_S = 12.0
WATCH = json.dumps({"action": "watch", "keys": ["odom"]})

Frame = tuple[float, str]  # (receive wall time, raw text): parsed after the run, off the clock


async def watch(url: str, origin: str, cookie: str, ready: asyncio.Barrier, window: list[float],
                frames: list[Frame]) -> None:
    async with connect(url, origin=origin, additional_headers={"Cookie": cookie}, max_size=None) as ws:
        await ws.send(WATCH)
        await ready.wait()
        while True:
            raw = await ws.recv()
            now = time.time()
            if now >= window[1]:
                return
            if now >= window[0]:
                frames.append((now, raw))


async def run(stack: Stack, clients: int) -> list[list[Frame]]:
    # Every socket shares one login: the server looks the session up per connection either way,
    # and a browser tab per user is what N sockets stand for, not N distinct accounts.
    cookie = login(stack, "vera")
    url = f"ws://127.0.0.1:{stack.web_port}/ws/live/"
    ready = asyncio.Barrier(clients + 1)
    window = [float("inf"), float("inf")]  # [start, end], set once every client watches
    frames: list[list[Frame]] = [[] for _ in range(clients)]
    tasks = [asyncio.create_task(watch(url, stack.url, cookie, ready, window, frames[i])) for i in range(clients)]
    await asyncio.wait_for(ready.wait(), 30)
    window[0] = time.time() + WARMUP_S
    window[1] = window[0] + MEASURE_S
    await asyncio.wait_for(asyncio.gather(*tasks), WARMUP_S + MEASURE_S + 10)
    return frames


def latencies_ms(frames: list[Frame]) -> list[tuple[float, float]]:
    """(publish → browser, link receive → browser) per odom update, in ms."""
    out = []
    for now, raw in frames:
        frame = json.loads(raw)
        updates = frame.get("updates") or ([frame] if frame.get("kind") == "update" else [])
        for update in updates:
            if update.get("key") == "odom":
                stamp = update["msg"]["header"]["stamp"]
                out.append(((now - stamp["secs"] - stamp["nsecs"] / 1e9) * 1000, (now - update["t"]) * 1000))
    return out


def introspect(stack: Stack) -> dict:
    with urllib.request.urlopen(f"http://127.0.0.1:{stack.video_port}/sim/introspect", timeout=5) as res:
        return json.loads(res.read())


def quantile(ordered: list[float], q: float) -> float:
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def main() -> None:
    logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(message)s")
    clients = int(sys.argv[1]) if len(sys.argv) > 1 else CLIENTS
    with Stack(sim_args=("--pose-rate", str(POSE_RATE_HZ))) as stack:
        stack.wait_robot_online()
        log.info("stack up; %d clients measuring for %.0f s", clients, MEASURE_S)
        frames = asyncio.run(run(stack, clients))
        sim = introspect(stack)
    per_client = [latencies_ms(f) for f in frames]
    samples = sorted(total for values in per_client for total, _ in values)
    fanout = sorted(part for values in per_client for _, part in values)
    if not samples or min(len(v) for v in per_client) == 0:
        raise SystemExit("some clients received no odom updates")
    subscriptions = sim["subscriptions"]
    print(f"clients: {clients}")
    print(f"samples: {len(samples)}")
    print(f"updates_per_client_per_s: {len(samples) / clients / MEASURE_S:.2f}")
    print(f"p50_ms: {quantile(samples, 0.5):.1f}")
    print(f"p99_ms: {quantile(samples, 0.99):.1f}")
    print(f"max_ms: {samples[-1]:.1f}")
    print(f"link_to_browser_p50_ms: {quantile(fanout, 0.5):.1f}")
    print(f"link_to_browser_p99_ms: {quantile(fanout, 0.99):.1f}")
    print(f"upstream_connections: {sim['clients']}")
    print(f"upstream_subscriptions_per_topic: {max(subscriptions.values())}")
    print(f"odom_subscriptions: {subscriptions.get(ri.topic('odom').name, 0)}")


if __name__ == "__main__":
    main()
