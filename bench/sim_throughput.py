"""How many messages/s the simulator delivers to 1 and to 20 rosbridge subscribers.

Starts ``python -m simulator`` in a subprocess (so the clients here do not share its GIL),
connects raw websocket subscribers, injects counted bursts through ``POST /sim/publish`` and
times until every subscriber has every message. Prints ``name: value`` lines.
"""

from __future__ import annotations

import asyncio
import json
import re
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

from websockets.asyncio.client import connect

ROOT = Path(__file__).resolve().parents[1]
TOPIC = "/bench/pose"
MSG = {"position": {"x": 1.25, "y": -3.5, "z": 0.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.38, "w": 0.92}}
PHASE_TIMEOUT_S = 10.0


def start_simulator() -> tuple[subprocess.Popen[str], str, int]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "simulator", "--port", "0", "--video-port", "0", "--quiet", "--startup-s", "1"],
        cwd=ROOT, stdout=subprocess.PIPE, text=True,
    )
    assert proc.stdout is not None
    line = proc.stdout.readline()
    m = re.search(r"listening on (ws://\S+) \(video on http://[^:]+:(\d+)\)", line)
    if not m:
        proc.kill()
        raise SystemExit(f"simulator did not start: {line!r}")
    return proc, m.group(1), int(m.group(2))


def inject(video_port: int, count: int) -> None:
    body = json.dumps({"topic": TOPIC, "msg": MSG, "count": count}).encode()
    req = urllib.request.Request(f"http://127.0.0.1:{video_port}/sim/publish", data=body, method="POST")
    with urllib.request.urlopen(req, timeout=30) as r:
        r.read()


async def measure(url: str, video_port: int, subscribers: int, count: int) -> float:
    conns = [await connect(url, compression=None, max_queue=None, max_size=None) for _ in range(subscribers)]
    try:
        for i, ws in enumerate(conns):
            await ws.send(json.dumps({"op": "subscribe", "id": f"b{i}", "topic": TOPIC,
                                      "type": "geometry_msgs/Pose"}))
        await asyncio.sleep(0.3)  # let the subscriptions land
        marker = f'"topic":"{TOPIC}"'

        async def drain(ws) -> int:
            got = 0
            while got < count:
                frame = await ws.recv()
                if marker in frame:
                    got += 1
            return got

        t0 = time.perf_counter()
        readers = [asyncio.create_task(drain(ws)) for ws in conns]
        await asyncio.to_thread(inject, video_port, count)
        done, pending = await asyncio.wait(readers, timeout=PHASE_TIMEOUT_S)
        elapsed = time.perf_counter() - t0
        for t in pending:
            t.cancel()
        delivered = sum(t.result() for t in done)
        if pending:  # the unfinished subscribers count as nothing: a conservative figure
            print(f"# warning: {len(pending)} subscriber(s) incomplete after {PHASE_TIMEOUT_S} s", file=sys.stderr)
        return delivered / elapsed
    finally:
        for ws in conns:
            await ws.close()


async def main() -> None:
    proc, url, video_port = start_simulator()
    try:
        one = await measure(url, video_port, 1, 20_000)
        twenty = await measure(url, video_port, 20, 2_000)
    finally:
        proc.terminate()
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()
    print(f"one_subscriber_msgs_per_s: {one:.1f}")
    print(f"twenty_subscribers_msgs_per_s: {twenty:.1f}")
    print(f"twenty_subscribers_per_subscriber_msgs_per_s: {twenty / 20:.1f}")


if __name__ == "__main__":
    asyncio.run(main())
