"""Map overlays through the real product (simulator + Daphne, embedded default): a section of bench/insight.py.

- ``laser_overlay_p99_ms``: 20 pages watch the laser overlay; latency is the wall time a page read
  the frame minus the scan's header stamp (the simulator stamps it as it publishes; same clock).
- ``costmap_update_to_image_ms``: a 4000 x 4000 global costmap is injected once through the
  simulator; then each partial update (200 x 200 cells) is timed from the moment it is handed to
  the simulator until a page has seen the new tile revision and fetched the patched tile over
  HTTP (its pixels checked).

As a section, ``run(stack)`` returns ``(name, value)`` lines; on its own (``.venv/bin/python
bench/insight_overlays.py``, no arguments) it starts its own stack and prints ``name: value``.
"""

from __future__ import annotations

import asyncio
import io
import json
import sys
import time
import urllib.request
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from _stats import quantile  # noqa: E402
from PIL import Image  # noqa: E402
from websockets.asyncio.client import connect  # noqa: E402

from robot import interface as ri  # noqa: E402
from robot.live.groups import OVERLAY_GLOBAL_COSTMAP_KEY, OVERLAY_SCAN_KEY  # noqa: E402
from tests.stack import Stack  # noqa: E402

PAGES = 20
LASER_WARMUP_S = 2.0
LASER_MEASURE_S = 10.0
COSTMAP_SIZE = 4000
UPDATE_CELLS = 200
UPDATES = 10


def _updates(raw: str | bytes) -> list[dict[str, Any]]:
    frame = json.loads(raw)
    return frame.get("updates") or ([frame] if frame.get("kind") == "update" else [])


async def _laser_page(url: str, origin: str, cookie: str, ready: asyncio.Barrier, window: list[float],
                      out: list[tuple[float, str | bytes]]) -> None:
    async with connect(url, origin=origin, additional_headers={"Cookie": cookie}, max_size=None) as ws:
        await ws.send(json.dumps({"action": "watch", "keys": [OVERLAY_SCAN_KEY]}))
        await ready.wait()
        while True:
            raw = await ws.recv()
            now = time.time()
            if now >= window[1]:
                return
            if now >= window[0]:
                out.append((now, raw))


async def laser_overlay(stack: Stack, cookie: str) -> dict[str, float]:
    url = f"ws://127.0.0.1:{stack.web_port}/ws/live/"
    ready = asyncio.Barrier(PAGES + 1)
    window = [float("inf"), float("inf")]
    frames: list[list[tuple[float, str | bytes]]] = [[] for _ in range(PAGES)]
    tasks = [asyncio.create_task(_laser_page(url, stack.url, cookie, ready, window, frames[i])) for i in range(PAGES)]
    await asyncio.wait_for(ready.wait(), 30)
    window[0] = time.time() + LASER_WARMUP_S
    window[1] = window[0] + LASER_MEASURE_S
    await asyncio.wait_for(asyncio.gather(*tasks), LASER_WARMUP_S + LASER_MEASURE_S + 15)
    latencies, upstream, points = [], [], []
    for page in frames:
        for now, raw in page:
            for update in _updates(raw):
                msg = update.get("msg") or {}
                if update.get("key") == OVERLAY_SCAN_KEY and msg.get("stamp") and "points" in msg:
                    latencies.append((now - msg["stamp"]) * 1000)
                    upstream.append((msg["received"] - msg["stamp"]) * 1000)
                    points.append(len(msg["points"]) // 2)
    per_page_hz = len(latencies) / PAGES / LASER_MEASURE_S
    return {
        "laser_overlay_p50_ms": round(quantile(sorted(latencies), 0.5), 1),
        "laser_overlay_p99_ms": round(quantile(sorted(latencies), 0.99), 1),
        "laser_publish_to_link_p50_ms": round(quantile(sorted(upstream), 0.5), 1),
        "laser_publish_to_link_p99_ms": round(quantile(sorted(upstream), 0.99), 1),
        "laser_overlay_frames_per_page_hz": round(per_page_hz, 1),
        "laser_overlay_points_per_frame": round(float(np.mean(points)) if points else 0.0),
    }


def _sim_publish(stack: Stack, topic: str, msg: dict[str, Any]) -> None:
    body = json.dumps({"topic": topic, "msg": msg}).encode()
    request = urllib.request.Request(f"http://127.0.0.1:{stack.video_port}/sim/publish", data=body,
                                     headers={"Content-Type": "application/json"}, method="POST")
    with urllib.request.urlopen(request, timeout=300) as answer:
        answer.read()


def _get(stack: Stack, path: str, cookie: str) -> bytes:
    request = urllib.request.Request(f"{stack.url}{path}", headers={"Cookie": cookie})
    with urllib.request.urlopen(request, timeout=30) as answer:
        return answer.read()


async def _next_meta(ws: Any, ok: Any, timeout: float) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while True:
        raw = await asyncio.wait_for(ws.recv(), max(0.01, deadline - time.monotonic()))
        for update in _updates(raw):
            if update.get("key") == OVERLAY_GLOBAL_COSTMAP_KEY and ok(update["msg"]):
                return update["msg"]


async def costmap_update(stack: Stack, cookie: str) -> dict[str, float]:
    url = f"ws://127.0.0.1:{stack.web_port}/ws/live/"
    loop = asyncio.get_running_loop()
    costmap, updates = ri.topic("global_costmap").name, ri.topic("global_costmap_updates").name
    async with connect(url, origin=stack.url, additional_headers={"Cookie": cookie}, max_size=None) as ws:
        await ws.send(json.dumps({"action": "watch", "keys": [OVERLAY_GLOBAL_COSTMAP_KEY]}))
        await _next_meta(ws, lambda m: True, 30)  # the simulator's own costmap: the subscription is up
        n = COSTMAP_SIZE
        cells = np.zeros((n, n), dtype=np.int8)
        cells[::400, :] = 100
        cells[:, ::400] = 100
        full = {"header": {"frame_id": "map"}, "info": {
            "resolution": 0.05, "width": n, "height": n, "map_load_time": {"secs": 0, "nsecs": 0},
            "origin": {"position": {"x": -100.0, "y": -100.0, "z": 0.0},
                       "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}},
            "data": cells.ravel().tolist()}
        t0 = time.perf_counter()
        await loop.run_in_executor(None, _sim_publish, stack, costmap, full)
        meta = await _next_meta(ws, lambda m: m["width"] == n, 300)
        first_ms = (time.perf_counter() - t0) * 1000
        durations, upstream, render = [], [], []
        tile = meta["tile"]
        for k in range(UPDATES):
            r, c = k % 7, (3 * k + 1) % 8  # tile row 7, column 0 holds the simulator's own updates
            x, top = c * tile + 100, r * tile + 100  # image rows run top-down
            y = n - top - UPDATE_CELLS
            value = 10 + k
            update = {"header": {"frame_id": "map"}, "x": x, "y": y, "width": UPDATE_CELLS, "height": UPDATE_CELLS,
                      "data": [value] * (UPDATE_CELLS * UPDATE_CELLS)}
            before = meta["tiles"][r][c]
            t0, wall0 = time.perf_counter(), time.time()
            await loop.run_in_executor(None, _sim_publish, stack, updates, update)
            meta = await _next_meta(ws, lambda m, r=r, c=c, before=before: m["tiles"][r][c] > before, 30)
            png = await loop.run_in_executor(
                None, _get, stack, f"{meta['url']}{r}-{c}-{meta['tiles'][r][c]}.png", cookie)
            durations.append((time.perf_counter() - t0) * 1000)
            upstream.append((meta["received"] - wall0) * 1000)
            render.append(meta["render_ms"])
            pixels = np.array(Image.open(io.BytesIO(png)))
            assert (pixels[100:100 + UPDATE_CELLS, 100:100 + UPDATE_CELLS] == value).all(), "tile not patched"
    return {
        "costmap_update_to_image_ms": round(quantile(sorted(durations), 0.5), 1),
        "costmap_update_to_image_max_ms": round(max(durations), 1),
        "costmap_update_handed_to_link_ms": round(quantile(sorted(upstream), 0.5), 1),
        "costmap_update_tile_render_ms": round(quantile(sorted(render), 0.5), 1),
        "costmap_full_4000_to_tiles_ms": round(first_ms),
    }


def run(stack: Stack) -> list[tuple[str, str]]:
    """This section's figures as (name, value) lines (the stack is up, the robot online)."""
    cookie = stack.login_cookie("vera")
    figures = asyncio.run(laser_overlay(stack, cookie))
    figures.update(asyncio.run(costmap_update(stack, cookie)))
    return [(name, str(value)) for name, value in figures.items()]


def main() -> None:
    with Stack() as stack:
        stack.wait_robot_online()
        for name, value in run(stack):
            print(f"{name}: {value}", flush=True)


if __name__ == "__main__":
    main()
