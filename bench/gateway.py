"""The front door under load: 200 rosbridge clients through the product against the same 200
straight to the simulator's rosbridge, in one run, at the simulator's full topic rates.

Each client subscribes, as a rosbridge client does, to the dashboard's topics plus ``/odom`` (the
probe: the simulator stamps each header with its wall clock as it publishes) and asks no throttle.
Through the product each client first gets its own single-use ticket (POST /api/frontdoor/ticket/).
Latency and loss are measured as in bench/live_fanout.py (whose client machinery this reuses): a
probe counts as lost for a client when neither it nor a newer one reached it within 1 s. Also
printed: how many subscriptions the simulator holds per topic while the 200 go through the product
(the product's upstream, reference subscriber excluded; target 1).

Run: ``.venv/bin/python bench/gateway.py`` (no arguments, ~2 min on a quiet machine). Prints ``name: value``.
The client process is this file run with ``--clients`` (internal).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import os
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from live_fanout import (  # noqa: E402
    BATCH,
    CLIENT_PROCS,
    KEYS,
    MEASURE_S,
    PROBE_KEY,
    WARMUP_S,
    Listener,
    Reference,
    cpu_seconds,
    merge_results,
    summarise,
)
from picows import WSMsgType, ws_connect  # noqa: E402

from robot import interface as ri  # noqa: E402

log = logging.getLogger("bench.gateway")
N = 200


# --- the client process ----------------------------------------------------------------


async def client(url: str, window: list[float]) -> Listener | Exception:
    try:
        transport, listener = await ws_connect(lambda: Listener(True, window), url, websocket_handshake_timeout=30,
                                               max_frame_size=1 << 26)
        assert isinstance(listener, Listener)
        listener.first.set_result(b"")
        for key in KEYS:
            t = ri.topic(key)
            transport.send(WSMsgType.TEXT, json.dumps({"op": "subscribe", "topic": t.name, "type": t.type}).encode())
    except Exception as exc:
        return exc
    return listener


async def run_clients(urls: list[str]) -> dict:
    window = [float("inf"), float("inf")]
    listeners: list[Listener] = []
    failed = 0
    step = BATCH // CLIENT_PROCS
    for start in range(0, len(urls), step):
        for result in await asyncio.gather(*(client(u, window) for u in urls[start:start + step])):
            if isinstance(result, Listener):
                listeners.append(result)
            else:
                failed += 1
                log.warning("client failed: %r", result)
    print("connected", flush=True)
    line = await asyncio.get_running_loop().run_in_executor(None, sys.stdin.readline)
    window[0] = float(line)
    window[1] = window[0] + MEASURE_S
    await asyncio.sleep(max(0.0, window[1] + 0.1 - time.time()))
    return {"failed": failed, "window": window, "samples": [lis.samples for lis in listeners] + [[]] * failed}


def client_main(path: str) -> None:
    urls = json.loads(Path(path).read_text())
    print("RESULT " + json.dumps(asyncio.run(run_clients(urls))), flush=True)
    os._exit(0)


# --- the driver --------------------------------------------------------------------------


def drive(urls: list[str], server_pids: list[int]) -> dict:
    shares = [urls[i::CLIENT_PROCS] for i in range(CLIENT_PROCS)]
    procs = []
    with tempfile.TemporaryDirectory() as folder:
        for i, share in enumerate(shares):
            path = Path(folder) / f"urls-{i}.json"
            path.write_text(json.dumps(share))
            procs.append(subprocess.Popen([sys.executable, __file__, "--clients", str(path)], stdout=subprocess.PIPE,
                                          stdin=subprocess.PIPE, text=True, cwd=ROOT,
                                          env={**os.environ, "DJANGO_SETTINGS_MODULE": ""}))
        for proc in procs:
            assert proc.stdout is not None
            for line in proc.stdout:
                if line.startswith("connected"):
                    break
    start = time.time() + WARMUP_S
    for proc in procs:
        assert proc.stdin is not None
        proc.stdin.write(f"{start!r}\n")
        proc.stdin.flush()
    time.sleep(max(0.0, start - time.time()))
    cpu0, t0 = cpu_seconds(server_pids), time.monotonic()
    time.sleep(MEASURE_S)
    merged: dict = {"failed": 0, "samples": [], "cpu_pct": (cpu_seconds(server_pids) - cpu0) / (time.monotonic() - t0)
                    * 100, "load": os.getloadavg()[0]}
    return merge_results(procs, merged)


def tickets(base: str, token: str, n: int) -> list[str]:
    def one() -> str:
        request = urllib.request.Request(f"{base}/api/frontdoor/ticket/", data=b"{}", method="POST",
                                         headers={"Authorization": f"Token {token}",
                                                  "Content-Type": "application/json"})
        with urllib.request.urlopen(request, timeout=30) as res:
            return json.loads(res.read())["url"]

    return [one() for _ in range(n)]


def subscriptions(video_port: int) -> dict[str, int]:
    with urllib.request.urlopen(f"http://127.0.0.1:{video_port}/sim/introspect", timeout=10) as res:
        return dict(json.loads(res.read())["subscriptions"])


def main() -> None:
    from tests.stack import PASSWORD, Stack

    with Stack() as stack:
        stack.wait_robot_online()
        request = urllib.request.Request(f"{stack.url}/api/auth/token/", data=json.dumps(
            {"username": "vera", "password": PASSWORD}).encode(), headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(request, timeout=30) as res:
            token = json.loads(res.read())["token"]
        reference = Reference(f"ws://127.0.0.1:{stack.sim_port}")
        reference.start()
        reference.ready.wait(10)
        log.info("%d clients through the front door", N)
        urls = tickets(stack.url, token, N)
        gateway = drive(urls, [stack.web.pid])
        held = subscriptions(stack.video_port)
        probe = ri.topic(PROBE_KEY).name
        per_topic = max(held.get(ri.topic(k).name, 0) - (1 if ri.topic(k).name == probe else 0) for k in KEYS)
        time.sleep(2.0)  # the gateway's clients are gone before the direct ones come
        log.info("%d clients straight to the simulator's rosbridge", N)
        direct = drive([f"ws://127.0.0.1:{stack.sim_port}"] * N, [stack.sim_proc.pid])
        g, d = summarise(gateway, reference.stamps), summarise(direct, reference.stamps)
        print(f"gateway_{N}_p50_ms: {g['p50']:.1f}")
        print(f"gateway_{N}_p99_ms: {g['p99']:.1f}")
        print(f"gateway_{N}_lost_pct: {g['lost']:.2f}")
        print(f"gateway_{N}_handshakes_failed: {gateway['failed']}")
        print(f"gateway_{N}_server_cpu_pct: {gateway['cpu_pct']:.1f}")
        print(f"gateway_upstream_subscriptions_per_topic: {per_topic}")
        print(f"direct_{N}_p50_ms: {d['p50']:.1f}")
        print(f"direct_{N}_p99_ms: {d['p99']:.1f}")
        print(f"direct_{N}_lost_pct: {d['lost']:.2f}")
        print(f"direct_{N}_server_cpu_pct: {direct['cpu_pct']:.1f}")
        print(f"gateway_loadavg: {gateway['load']:.1f}", flush=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("--clients")
    args = parser.parse_args()
    if args.clients:
        client_main(args.clients)
    else:
        logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(message)s")
        main()
