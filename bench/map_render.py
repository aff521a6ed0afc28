"""How fast a map gets from the robot to a browser's screen.

1. In process, for the default (400x300) and the large (4000x4000) simulator maps: decoding
   the rosbridge frame as the link does (``robot.link.wire.decode_frame``: the grid's integers
   parsed by numpy, not ``json``), conversion + versioning, rendering, and the sum (message
   to image). ``*_json_decode_ms`` is what plain ``json.loads`` (roslibpy's own) would take.
2. The real product (simulator + Daphne, ``tests/stack.py``) with a real headless Chromium:
   from the link holding the whole frame to the map image rendered (server log), from the
   link connecting to that image (includes the simulator sending 32 MB), the longest
   /healthz answer while the large map arrives (how long the event loop stalls), and first
   paint of the map page (``page.goto`` until the page set ``data-ready``: image loaded and
   overlay drawn), cold and with the image cached.

Run: .venv/bin/python bench/map_render.py
"""

from __future__ import annotations

import dataclasses
import json
import statistics
import sys
import tempfile
import threading
import time
import urllib.request
from datetime import UTC, datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from robot import interface as ri  # noqa: E402
from robot.link.wire import decode_frame  # noqa: E402
from robot.navigation.mapimage import render_map  # noqa: E402
from simulator import messages, world  # noqa: E402
from tests.browser.support import CHROMIUM, CHROMIUM_ARGS, login  # noqa: E402
from tests.stack import Stack  # noqa: E402


def grid_frame(w: world.WorldMap) -> bytes:
    msg = {"header": {"frame_id": "map"}, "info": {
        "resolution": w.resolution, "width": w.width, "height": w.height,
        "origin": {"position": {"x": w.origin_x, "y": w.origin_y, "z": 0.0},
                   "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}, "data": w.grid.ravel().tolist()}
    return messages.encode({"op": "publish", "topic": ri.topic("map").name, "msg": msg}).encode()


def in_process(name: str, w: world.WorldMap, runs: int = 5) -> None:
    frame = grid_frame(w)
    array_topics = frozenset({ri.topic("map").name})
    totals, decodes, converts, renders = [], [], [], []
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as tmp:  # a new map version every run: nothing cached
            t0 = time.perf_counter()
            msg = decode_frame(frame, array_topics=array_topics)["msg"]
            t1 = time.perf_counter()
            rendered = render_map(msg, Path(tmp))
            t2 = time.perf_counter()
            png_kb = rendered.png.stat().st_size / 1000
        decodes.append((t1 - t0) * 1000)
        converts.append(rendered.convert_ms)
        renders.append(rendered.render_ms)
        totals.append((t2 - t0) * 1000)
    t0 = time.perf_counter()
    json.loads(frame)
    json_ms = (time.perf_counter() - t0) * 1000
    print(f"{name}_frame_mb: {len(frame) / 1e6:.1f}")
    print(f"{name}_json_decode_ms: {json_ms:.0f}")
    print(f"{name}_decode_ms: {statistics.median(decodes):.0f}")
    print(f"{name}_convert_ms: {statistics.median(converts):.0f}")
    print(f"{name}_render_ms: {statistics.median(renders):.0f}")
    print(f"{name}_message_to_image_median_ms: {statistics.median(totals):.0f}")
    print(f"{name}_message_to_image_worst_ms: {max(totals):.0f}")
    print(f"{name}_png_kb: {png_kb:.0f}")


class HealthProbe(threading.Thread):
    """Ask /healthz back to back and keep the slowest answer (event-loop stalls)."""

    def __init__(self, url: str) -> None:
        super().__init__(daemon=True)
        self.url, self.worst, self.running = url, 0.0, True

    def run(self) -> None:
        while self.running:
            t0 = time.perf_counter()
            try:
                urllib.request.urlopen(f"{self.url}/healthz", timeout=10).read()
            except OSError:
                time.sleep(0.02)
                continue
            self.worst = max(self.worst, time.perf_counter() - t0)
            time.sleep(0.01)


def first_paint(browser, stack: Stack) -> tuple[float, float]:
    context = browser.new_context(viewport={"width": 1280, "height": 900})
    page = context.new_page()
    try:
        login(page, stack, "vera")
        times = []
        for _ in range(2):  # cold, then with the image in the browser's cache
            t0 = time.perf_counter()
            page.goto(f"{stack.url}/map/")
            page.wait_for_selector('#map-view[data-ready="1"]', timeout=30_000)
            times.append((time.perf_counter() - t0) * 1000)
        return times[0], times[1]
    finally:
        context.close()


def log_line(stack: Stack, needle: str, timeout: float = 40.0, *, nth: int = 1) -> tuple[float, str]:
    """Epoch seconds and text of the ``nth`` web-server log line containing ``needle``."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        lines = [line for line in stack.log("web").splitlines() if needle in line]
        if len(lines) >= nth:
            line = lines[nth - 1]
            stamp = datetime.strptime(line[:23], "%Y-%m-%d %H:%M:%S,%f").replace(tzinfo=UTC)
            return stamp.timestamp(), line
        time.sleep(0.05)
    raise SystemExit(f"no {needle!r} in the server log:\n" + stack.log("web")[-2000:])


def receive_ms(line: str) -> float:
    return float(line.split(" frame in ")[1].split(" ms")[0])


def live_update(browser, stack: Stack, w: world.WorldMap) -> tuple[float, float]:
    """A new large map while the map page is open: (frame received, frame arriving) -> new image on screen."""
    context = browser.new_context(viewport={"width": 1280, "height": 900})
    page = context.new_page()
    try:
        login(page, stack, "vera", next_path="/map/")
        page.wait_for_selector('#map-view[data-ready="1"]', timeout=30_000)
        old = page.get_attribute("#map-view", "data-map-version")
        grid = w.grid.copy()
        grid[10:200, 10:200] = 100  # a new version of the same floor
        msg = json.loads(grid_frame(dataclasses.replace(w, grid=grid)))["msg"]
        body = json.dumps({"topic": ri.topic("map").name, "msg": msg}).encode()
        request = urllib.request.Request(f"http://127.0.0.1:{stack.video_port}/sim/publish", data=body, method="POST",
                                         headers={"Content-Type": "application/json"})
        urllib.request.urlopen(request, timeout=120).read()
        page.wait_for_function(
            """(old) => {
                const root = document.getElementById('map-view'), img = document.getElementById('map-image');
                return root.dataset.mapVersion !== old && img.complete && img.naturalWidth > 0
                    && img.src.endsWith(root.dataset.mapVersion + '.png');
            }""", arg=old, timeout=60_000, polling=5)
        shown = time.time()
        arrived, line = log_line(stack, "robot.link.rosclient: received a ", nth=2)
        return (shown - arrived) * 1000, (shown - arrived) * 1000 + receive_ms(line)
    finally:
        context.close()


def log_time(stack: Stack, needle: str) -> float:
    return log_line(stack, needle)[0]


def end_to_end(browser, name: str, sim_args: tuple[str, ...], *, large: bool) -> None:
    # The server logs in its TIME_ZONE: UTC, so its log times compare with this process's clock.
    with Stack(sim_args=sim_args, env={"TIME_ZONE": "UTC"}) as stack:
        probe = HealthProbe(stack.url)
        probe.start()
        stack.wait_robot_online(timeout=40)
        online = log_time(stack, "robot link connected")
        ready = log_time(stack, "robot.navigation.handlers: map ")
        probe.running = False
        if large:  # small frames are decoded where they arrive, without a log line
            arrived, line = log_line(stack, "robot.link.rosclient: received a ")
            print(f"{name}_frame_receive_ms: {receive_ms(line):.0f}")
            print(f"{name}_frame_to_server_image_ms: {(ready - arrived) * 1000:.0f}")
        cold, cached = first_paint(browser, stack)
        if large:
            received_to_screen, arriving_to_screen = live_update(browser, stack, world.large())
            print(f"{name}_live_frame_received_to_screen_ms: {received_to_screen:.0f}")
            print(f"{name}_live_frame_arriving_to_screen_ms: {arriving_to_screen:.0f}")
    print(f"{name}_online_to_server_image_ms: {(ready - online) * 1000:.0f}")
    print(f"{name}_healthz_worst_ms: {probe.worst * 1000:.0f}")
    print(f"{name}_first_paint_ms: {cold:.0f}")
    print(f"{name}_first_paint_cached_ms: {cached:.0f}")


def main() -> None:
    from playwright.sync_api import sync_playwright

    in_process("default", world.glassgarden())
    in_process("large", world.large())
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            end_to_end(browser, "default", (), large=False)
            end_to_end(browser, "large", ("--map", "large"), large=True)
        finally:
            browser.close()


if __name__ == "__main__":
    main()
