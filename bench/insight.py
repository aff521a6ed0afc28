"""What seeing inside the robot costs, through the real product: simulator + Daphne (embedded default).

One stack, then each section in ``SECTIONS`` in turn; a section takes the running stack and returns
``(name, value)`` lines (the unit in the name). Sections:

- ``topics``: ``PAGES`` websocket clients (one login, like browser tabs) open the laser topic, a
  10 Hz topic, on the Topics page's socket. ``topic_echo_p99_ms``: the simulator stamps each scan's
  header as it publishes; latency is the wall time a client read the frame minus that stamp (same
  machine, same clock). ``topics_upstream_subscriptions``: the simulator's own count of
  subscriptions to that topic while all of them watch (must be 1). ``idle_unsubscribe_s``: from the
  last client closing to the simulator seeing the unsubscribe (the configured grace period,
  ``TOPICS_IDLE_GRACE_S``, plus what it takes to notice).

- ``map_overlays`` (bench/insight_overlays.py): the laser overlay's latency and a costmap update's
  time to a patched image.

- ``introspection`` (bench/insight_introspection.py): an operator's event until 20 state machine
  pages show the new active state; a diagnostic level change until 20 dashboards have it.

Other sections are functions of the same shape added to ``SECTIONS``.
Usage: ``.venv/bin/python bench/insight.py`` (no arguments). Prints ``name: value``.
"""

from __future__ import annotations

import asyncio
import json
import logging
import sys
import time
import urllib.request
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from _stats import quantile  # noqa: E402
from insight_introspection import run as introspection  # noqa: E402
from insight_overlays import run as map_overlays  # noqa: E402
from websockets.asyncio.client import connect  # noqa: E402

from robot import interface as ri  # noqa: E402
from tests.stack import Stack  # noqa: E402

log = logging.getLogger("bench.insight")

Line = tuple[str, str]
Section = Callable[[Stack], list[Line]]

PAGES = 20
WARMUP_S = 2.0
MEASURE_S = 12.0
IDLE_GRACE_S = 5.0  # the setting's default, set explicitly so the figure says what it measures
UNSUBSCRIBE_TIMEOUT_S = 60.0


def introspect(stack: Stack) -> dict:
    with urllib.request.urlopen(f"http://127.0.0.1:{stack.video_port}/sim/introspect", timeout=5) as res:
        return json.loads(res.read())


def upstream_subscriptions(stack: Stack, topic: str) -> int:
    return int(introspect(stack)["subscriptions"].get(topic, 0))


# --- topics ------------------------------------------------------------------------------

Frame = tuple[float, str]  # (receive wall time, raw text): parsed after the run, off the clock


async def _watch_topic(url: str, origin: str, cookie: str, topic: str, ready: asyncio.Barrier,
                       window: list[float], frames: list[Frame], release: asyncio.Event) -> None:
    async with connect(url, origin=origin, additional_headers={"Cookie": cookie}, max_size=None) as ws:
        await ws.send(json.dumps({"action": "watch_topic", "topic": topic}))
        await ready.wait()
        while not release.is_set():
            try:
                raw = await asyncio.wait_for(ws.recv(), 0.5)
            except TimeoutError:
                continue
            now = time.time()
            if window[0] <= now < window[1]:
                frames.append((now, raw))


def _echo_latencies_ms(frames: list[Frame], key: str) -> list[tuple[float, float]]:
    """(publish → page, link receive → page) per update of ``key``, in ms."""
    out = []
    for now, raw in frames:
        frame = json.loads(raw)
        for update in frame.get("updates") or ():
            if update.get("key") == key:
                stamp = update["msg"]["header"]["stamp"]
                out.append(((now - stamp["secs"] - stamp["nsecs"] / 1e9) * 1000, (now - update["t"]) * 1000))
    return out


async def _topics(stack: Stack, topic: str) -> tuple[list[list[Frame]], int, float]:
    cookie = stack.login_cookie("vera")
    url = f"ws://127.0.0.1:{stack.web_port}/ws/live/"
    ready = asyncio.Barrier(PAGES + 1)
    release = asyncio.Event()
    window = [float("inf"), float("inf")]
    frames: list[list[Frame]] = [[] for _ in range(PAGES)]
    tasks = [asyncio.create_task(_watch_topic(url, stack.url, cookie, topic, ready, window, frames[i], release))
             for i in range(PAGES)]
    await asyncio.wait_for(ready.wait(), 30)
    window[0] = time.time() + WARMUP_S
    window[1] = window[0] + MEASURE_S
    await asyncio.sleep(WARMUP_S + MEASURE_S)
    subscriptions = await asyncio.to_thread(upstream_subscriptions, stack, topic)
    release.set()
    await asyncio.wait_for(asyncio.gather(*tasks), 10)
    closed = time.monotonic()
    deadline = closed + UNSUBSCRIBE_TIMEOUT_S
    while await asyncio.to_thread(upstream_subscriptions, stack, topic) and time.monotonic() < deadline:
        await asyncio.sleep(0.05)
    return frames, subscriptions, time.monotonic() - closed


def topics(stack: Stack) -> list[Line]:
    topic = ri.topic("scan")
    frames, subscriptions, idle_s = asyncio.run(_topics(stack, topic.name))
    per_page = [_echo_latencies_ms(f, f"topic:{topic.name}") for f in frames]
    samples = sorted(total for page in per_page for total, _ in page)
    fanout = sorted(part for page in per_page for _, part in page)
    if not samples or min(len(p) for p in per_page) == 0:
        raise SystemExit(f"some pages received no {topic.name} messages")
    return [
        ("topic_echo_topic", topic.name),
        ("topic_echo_pages", str(PAGES)),
        ("topic_echo_updates_per_page_per_s", f"{len(samples) / PAGES / MEASURE_S:.2f}"),
        ("topic_echo_p50_ms", f"{quantile(samples, 0.5):.1f}"),
        ("topic_echo_p99_ms", f"{quantile(samples, 0.99):.1f}"),
        ("topic_echo_max_ms", f"{samples[-1]:.1f}"),
        ("topic_echo_link_to_page_p50_ms", f"{quantile(fanout, 0.5):.1f}"),
        ("topic_echo_link_to_page_p99_ms", f"{quantile(fanout, 0.99):.1f}"),
        ("topics_upstream_subscriptions", str(subscriptions)),
        ("topics_idle_grace_s", f"{IDLE_GRACE_S:g}"),
        ("idle_unsubscribe_s", f"{idle_s:.2f}"),
    ]


SECTIONS: list[Section] = [topics, map_overlays, introspection]


def main() -> None:
    logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(message)s")
    with Stack(env={"TOPICS_IDLE_GRACE_S": str(IDLE_GRACE_S)}) as stack:
        stack.wait_robot_online()
        for section in SECTIONS:
            log.info("section %s", section.__name__)
            for name, value in section(stack):
                print(f"{name}: {value}", flush=True)


if __name__ == "__main__":
    main()
