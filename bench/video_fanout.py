"""The camera relay under load: 20 logged-in viewers of one camera stream through the product.

Starts the simulator (its web_video_server look-alike stamps every frame with ``X-Timestamp``,
its wall clock as it sends) and Daphne, opens 20 ``/video/stream`` viewers for 20 s and prints:
``video_upstream_streams`` (the most MJPEG streams the simulator served at once: must be 1),
``video_frame_p99_ms`` (frame stamp → arrival at a viewer), ``video_fps_per_viewer``.

Run: ``.venv/bin/python bench/video_fanout.py`` (no arguments, ~40 s). Prints ``name: value``.
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
sys.path.insert(0, str(ROOT / "bench"))

import aiohttp  # noqa: E402
from _stats import quantile  # noqa: E402
from teleop_latency import login  # noqa: E402

from tests.stack import Stack  # noqa: E402

log = logging.getLogger("bench.video_fanout")

VIEWERS = 20
WARMUP_S = 2.0
MEASURE_S = 20.0



async def viewer(url: str, cookie: str, window: list[float], out: list[float]) -> None:
    timeout = aiohttp.ClientTimeout(total=None, sock_read=10)
    async with aiohttp.ClientSession(timeout=timeout, headers={"Cookie": cookie}) as session:
        async with session.get(url) as response:
            if response.status != 200:
                raise SystemExit(f"viewer got {response.status}")
            reader = aiohttp.MultipartReader(response.headers, response.content)
            while (part := await reader.next()) is not None:
                assert isinstance(part, aiohttp.BodyPartReader)
                await part.read()
                now = time.time()
                if now >= window[1]:
                    return
                if now >= window[0]:
                    out.append((now - float(part.headers["X-Timestamp"])) * 1000)


def upstream_streams(stack: Stack) -> int:
    with urllib.request.urlopen(f"http://127.0.0.1:{stack.video_port}/sim/introspect", timeout=5) as res:
        return int(json.loads(res.read())["video_streams"])


async def run(stack: Stack, cookie: str) -> tuple[list[list[float]], int]:
    now = time.time()
    window = [now + WARMUP_S, now + WARMUP_S + MEASURE_S]
    frames: list[list[float]] = [[] for _ in range(VIEWERS)]
    url = f"{stack.url}/video/stream"
    tasks = [asyncio.create_task(viewer(url, cookie, window, frames[i])) for i in range(VIEWERS)]
    most = 0
    while not all(t.done() for t in tasks):
        most = max(most, await asyncio.to_thread(upstream_streams, stack))
        await asyncio.sleep(0.5)
    for task in tasks:
        task.result()
    return frames, most


def main() -> None:
    logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(message)s")
    # Twenty viewers as one person: let one person watch that many (the cap per person is 3).
    with Stack(env={"CAMERA_STREAMS_PER_PERSON": str(VIEWERS)}) as stack:
        stack.wait_robot_online()
        cookie = login(stack, "vera")
        # The camera recorder's own stream, at its size, is open before any viewer comes.
        deadline = time.monotonic() + 10
        while (recorder := upstream_streams(stack)) < 1 and time.monotonic() < deadline:
            time.sleep(0.1)
        log.info("%d viewers for %.0f s", VIEWERS, MEASURE_S)
        frames, most = asyncio.run(run(stack, cookie))
    latencies = sorted(ms for viewer_frames in frames for ms in viewer_frames)
    print(f"video_upstream_streams: {most - recorder} (for {VIEWERS} viewers)")
    print(f"video_recorder_streams: {recorder}")
    print(f"video_frame_p50_ms: {quantile(latencies, 0.5):.1f}")
    print(f"video_frame_p99_ms: {quantile(latencies, 0.99):.1f}")
    print(f"video_fps_per_viewer: {len(latencies) / VIEWERS / MEASURE_S:.2f}")


if __name__ == "__main__":
    main()
