"""Live fan-out under load: N browsers through the product against N browsers straight on rosbridge.

Starts the simulator at its full topic rates (odom at 10 Hz is the probe: the simulator stamps each
``/odom`` header with its wall clock as it publishes), then the product (real Daphne, embedded), and
drives N logged-in websocket clients from a separate process (one per web process when there
are several), each watching the dashboard's keys plus odom. The same N clients then subscribe to
the same topics straight on the simulator's rosbridge port. A reference subscriber in this process
records every probe the simulator sent; a probe counts as lost for a client when neither it nor a
newer one reached that client within 1 s.

Second section, scaled: a private Redis, ``manage.py robotlink`` and two Daphne processes, with
1000 clients split across the two.

Run: ``.venv/bin/python bench/live_fanout.py`` (no arguments, ~3 min on a quiet machine). Prints ``name: value``.
The client process is this file run with ``--clients`` (internal).
"""

from __future__ import annotations

import argparse
import asyncio
import bisect
import json
import logging
import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from _stats import quantile  # noqa: E402
from picows import WSFrame, WSListener, WSMsgType, WSTransport, ws_connect  # noqa: E402
from websockets.exceptions import ConnectionClosed  # noqa: E402

from robot import interface as ri  # noqa: E402

log = logging.getLogger("bench.live_fanout")

SIZES = (50, 200, 500)
SCALED = 1000
BATCH = 50  # connections opened at once per web process (shared by its client processes)
WARMUP_S = 1.5
MEASURE_S = 6.0
LOST_AFTER_S = 1.0
IDLE_SOCKETS = 200
# Client processes per web process: one Python process reading hundreds of sockets would measure
# itself (its CPU is printed as *_client_cpu_pct so a saturated client shows).
CLIENT_PROCS = 2
PROBE_KEY = "odom"
HOME_KEYS = (
    "battery_soc", "battery_voltage", "battery_recharge_state", "motors_state", "robot_mode",
    "state_change", "state_transitions", "emotional_state", "emotion_system_status",
    "text_to_speech", "tts_feedback", "current_location", "rosout", "robot_pose", "smach_status",
)
KEYS = [*HOME_KEYS, PROBE_KEY]


# --- the client process ----------------------------------------------------------------


# The probe's stamp read straight from the bytes: parsing every frame's JSON would make the client
# process, not the server, the bottleneck. Product fragments are compact JSON
# {"key":"odom","msg":{"header":{...,"stamp":{...}}}}; rosbridge messages carry "topic":"/odom".
_STAMP = rb'"header":\s*\{[^{}]*"stamp":\s*\{\s*"secs":\s*(\d+),\s*"nsecs":\s*(\d+)'
PRODUCT_PROBE = re.compile(rb'"key":"odom","msg":\{' + _STAMP)
DIRECT_PROBE = re.compile(_STAMP)


def probe_stamps(raw: bytes, direct: bool) -> list[float]:
    """The probe's send times in one frame (product frame or rosbridge message)."""
    if direct:
        if b'"/odom"' not in raw:
            return []
        found = DIRECT_PROBE.findall(raw)[:1]
    else:
        found = PRODUCT_PROBE.findall(raw)
    return [int(secs) + int(nsecs) / 1e9 for secs, nsecs in found]


class Listener(WSListener):
    """One client socket (picows: frames arrive as callbacks straight from the read, so the receive
    time is taken before anything else, and a frame costs microseconds, not an asyncio task switch)."""

    def __init__(self, direct: bool, window: list[float]) -> None:
        self.direct = direct
        self.window = window
        self.samples: list[tuple[float, float]] = []
        self.first: asyncio.Future[bytes] = asyncio.get_running_loop().create_future()
        self.partial: bytes | None = None

    def on_ws_frame(self, transport: WSTransport, frame: WSFrame) -> None:
        now = time.time()
        if frame.msg_type == WSMsgType.CLOSE:
            transport.disconnect()
            return
        if frame.msg_type == WSMsgType.CONTINUATION or not frame.fin:  # never sent in practice
            self.partial = (self.partial or b"") + frame.get_payload_as_bytes()
            if not frame.fin:
                return
            raw, self.partial = self.partial, None
        elif frame.msg_type == WSMsgType.TEXT:
            raw = frame.get_payload_as_bytes()
        else:
            return
        if not self.first.done():
            self.first.set_result(raw)
            return
        if self.window[0] <= now < self.window[1]:
            for stamp in probe_stamps(raw, self.direct):
                self.samples.append((stamp, now))


async def client(url: str, cookie: str, mode: str, window: list[float]) -> Listener | Exception:
    direct = mode == "direct"
    headers = {} if direct else {"Cookie": cookie, "Origin": url.replace("ws://", "http://").split("/ws/")[0]}
    try:
        transport, listener = await ws_connect(lambda: Listener(direct, window), url, extra_headers=headers,
                                               websocket_handshake_timeout=30, max_frame_size=1 << 26)
        assert isinstance(listener, Listener)
        if direct:
            listener.first.set_result(b"")
            for key in KEYS:
                t = ri.topic(key)
                transport.send(WSMsgType.TEXT, json.dumps({"op": "subscribe", "topic": t.name,
                                                           "type": t.type}).encode())
        else:
            first = json.loads(await asyncio.wait_for(listener.first, 30))
            if first.get("kind") != "status":
                raise RuntimeError(f"first frame was {first}")
            if mode == "watch":
                transport.send(WSMsgType.TEXT, json.dumps({"action": "watch", "keys": KEYS}).encode())
    except Exception as exc:
        return exc
    return listener


async def run_clients(urls: list[str], cookie: str, mode: str, n: int) -> dict:
    window = [float("inf"), float("inf")]
    listeners: list[Listener] = []
    failed = 0
    step = BATCH // CLIENT_PROCS
    for start in range(0, n, step):
        batch = [client(urls[i % len(urls)], cookie, mode, window) for i in range(start, min(n, start + step))]
        for result in await asyncio.gather(*batch):
            if isinstance(result, Listener):
                listeners.append(result)
            else:
                failed += 1
                log.warning("client failed: %r", result)
    print("connected", flush=True)
    # The driver answers with the window's start (epoch seconds), the same for every client process.
    line = await asyncio.get_running_loop().run_in_executor(None, sys.stdin.readline)
    if mode == "idle":
        return {"failed": failed}
    window[0] = float(line)
    window[1] = window[0] + MEASURE_S
    await asyncio.sleep(max(0.0, window[1] + 0.1 - time.time()))
    samples = [listener.samples for listener in listeners] + [[] for _ in range(failed)]
    return {"failed": failed, "window": window, "samples": samples}


def client_main(args: argparse.Namespace) -> None:
    result = asyncio.run(run_clients(args.url, os.environ.get("BENCH_COOKIE", ""), args.mode, args.clients))
    print("RESULT " + json.dumps(result), flush=True)
    os._exit(0)  # skip closing hundreds of sockets one by one


# --- the driver --------------------------------------------------------------------------


class Reference(threading.Thread):
    """Every probe the simulator sent, heard by one quiet subscriber straight on rosbridge."""

    def __init__(self, rosbridge_url: str) -> None:
        super().__init__(daemon=True)
        self.url = rosbridge_url
        self.stamps: list[float] = []
        self.ready = threading.Event()

    def run(self) -> None:
        from websockets.sync.client import connect as sync_connect

        t = ri.topic(PROBE_KEY)
        with sync_connect(self.url, max_size=None) as ws:
            ws.send(json.dumps({"op": "subscribe", "topic": t.name, "type": t.type}))
            self.ready.set()
            try:
                for raw in ws:
                    self.stamps.extend(probe_stamps(raw.encode() if isinstance(raw, str) else raw, direct=True))
            except ConnectionClosed:
                return  # the stack stopped


def cpu_seconds(pids: list[int]) -> float:
    total = 0.0
    for pid in pids:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    return total


def rss_kb(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    return 0


def spawn_clients(urls: list[str], cookie: str, mode: str, n: int) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, __file__, "--clients", str(n), "--mode", mode, *[a for u in urls for a in ("--url", u)]],
        stdout=subprocess.PIPE, stdin=subprocess.PIPE, text=True, cwd=ROOT,
        env={**os.environ, "BENCH_COOKIE": cookie, "DJANGO_SETTINGS_MODULE": ""},
    )


def wait_connected(proc: subprocess.Popen) -> None:
    assert proc.stdout is not None
    for line in proc.stdout:
        if line.startswith("connected"):
            return
    raise RuntimeError(f"client process ended with {proc.wait()}")


def profile(pids: list[int], name: str) -> list[subprocess.Popen]:
    """With BENCH_PYSPY=DIR: py-spy samples each server process over the window (raw folded stacks)."""
    out = os.environ.get("BENCH_PYSPY")
    if not out:
        return []
    Path(out).mkdir(parents=True, exist_ok=True)
    return [subprocess.Popen([str(Path(sys.executable).parent / "py-spy"), "record", "-p", str(pid), "-d",
                              str(int(MEASURE_S)), "-r", "250", "-f", "raw", "-o", f"{out}/{name}-{pid}.txt"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) for pid in pids]


def drive(urls: list[str], cookie: str, mode: str, n: int, server_pids: list[int]) -> dict:
    """N clients from CLIENT_PROCS processes per web process (each its share), one measuring window for all."""
    shares = [(url, n // (len(urls) * CLIENT_PROCS) + (i < n % (len(urls) * CLIENT_PROCS)))
              for i, url in enumerate(urls * CLIENT_PROCS)]
    procs = [spawn_clients([url], cookie, mode, share) for url, share in shares if share]
    for proc in procs:
        wait_connected(proc)
    start = time.time() + WARMUP_S
    for proc in procs:
        assert proc.stdin is not None
        proc.stdin.write(f"{start!r}\n")
        proc.stdin.flush()
    time.sleep(max(0.0, start - time.time()))
    client_pids = [proc.pid for proc in procs]
    profilers = profile(server_pids, f"{mode}-{n}")
    cpu0, client0, t0 = cpu_seconds(server_pids), cpu_seconds(client_pids), time.monotonic()
    time.sleep(MEASURE_S)
    for profiler in profilers:
        profiler.wait(30)
    elapsed = time.monotonic() - t0
    cpu = (cpu_seconds(server_pids) - cpu0) / elapsed * 100
    client_cpu = (cpu_seconds(client_pids) - client0) / elapsed * 100
    merged: dict = {"failed": 0, "samples": [], "cpu_pct": cpu, "client_cpu_pct": client_cpu,
                    "load": os.getloadavg()[0]}
    return merge_results(procs, merged)


def merge_results(procs: list[subprocess.Popen], merged: dict) -> dict:
    """The listener processes' RESULT lines added into ``merged`` (failures, samples, their window)."""
    for proc in procs:
        assert proc.stdout is not None
        for line in proc.stdout:
            if line.startswith("RESULT "):
                result = json.loads(line[7:])
                merged["failed"] += result["failed"]
                merged["samples"] += result["samples"]
                merged["window"] = result["window"]
        proc.wait(30)
    return merged


def idle_memory(url: str, cookie: str, pid: int) -> float:
    before = rss_kb(pid)
    proc = spawn_clients([url], cookie, "idle", IDLE_SOCKETS)
    wait_connected(proc)
    time.sleep(1.0)
    after = rss_kb(pid)
    assert proc.stdin is not None
    proc.stdin.write("0\n")
    proc.stdin.flush()
    proc.wait(60)
    return (after - before) / IDLE_SOCKETS



def summarise(result: dict, sent: list[float]) -> dict[str, float]:
    w0, w1 = result["window"]
    latencies = sorted((now - stamp) * 1000 for samples in result["samples"] for stamp, now in samples)
    due = [s for s in sent if w0 + 0.2 <= s <= w1 - LOST_AFTER_S]  # each had its full second in the window
    lost = 0
    for samples in result["samples"]:
        samples.sort()
        stamps = [s for s, _ in samples]
        earliest = [0.0] * len(samples)  # the earliest arrival of this probe or any newer one
        best = float("inf")
        for i in range(len(samples) - 1, -1, -1):
            best = min(best, samples[i][1])
            earliest[i] = best
        for s in due:
            i = bisect.bisect_left(stamps, s - 1e-6)
            if i == len(samples) or earliest[i] > s + LOST_AFTER_S:
                lost += 1
    total = len(due) * len(result["samples"])
    return {"p50": quantile(latencies, 0.5), "p99": quantile(latencies, 0.99),
            "lost": 100.0 * lost / total if total else float("nan")}


def report(prefix: str, result: dict, sent: list[float]) -> None:
    figures = summarise(result, sent)
    print(f"{prefix}_p50_ms: {figures['p50']:.1f}")
    print(f"{prefix}_p99_ms: {figures['p99']:.1f}")
    print(f"{prefix}_lost_pct: {figures['lost']:.2f}")
    print(f"{prefix}_handshakes_failed: {result['failed']}")
    print(f"{prefix}_server_cpu_pct: {result['cpu_pct']:.1f}")
    print(f"{prefix}_client_cpu_pct: {result['client_cpu_pct']:.0f}")
    print(f"{prefix}_loadavg: {result['load']:.1f}", flush=True)


def embedded_section(sizes: tuple[int, ...]) -> None:
    from teleop_latency import login

    from tests.stack import Stack

    with Stack() as stack:
        stack.wait_robot_online()
        cookie = login(stack, "vera")
        url = f"ws://127.0.0.1:{stack.web_port}/ws/live/"
        reference = Reference(f"ws://127.0.0.1:{stack.sim_port}")
        reference.start()
        reference.ready.wait(10)
        print(f"fanout_mem_per_socket_kb: {idle_memory(url, cookie, stack.web.pid):.1f}", flush=True)
        for n in sizes:
            log.info("embedded: %d clients through the product", n)
            result = drive([url], cookie, "watch", n, [stack.web.pid])
            report(f"fanout_{n}", result, reference.stamps)
            log.info("embedded: %d clients straight to rosbridge", n)
            result = drive([f"ws://127.0.0.1:{stack.sim_port}"], "", "direct", n, [stack.sim_proc.pid])
            figures = summarise(result, reference.stamps)
            print(f"direct_{n}_p50_ms: {figures['p50']:.1f}")
            print(f"direct_{n}_p99_ms: {figures['p99']:.1f}")
            print(f"direct_{n}_server_cpu_pct: {result['cpu_pct']:.1f}")
            print(f"direct_{n}_client_cpu_pct: {result['client_cpu_pct']:.0f}", flush=True)


def scaled_section() -> None:
    from teleop_latency import login

    from tests.stack import Stack, free_port

    redis_port = free_port()
    redis = subprocess.Popen(["redis-server", "--port", str(redis_port), "--save", "", "--appendonly", "no"],
                             stdout=subprocess.DEVNULL, start_new_session=True)
    try:
        with Stack(redis_url=f"redis://127.0.0.1:{redis_port}/0", webs=2) as stack:
            stack.wait_robot_online()
            cookie = login(stack, "vera")
            urls = [f"ws://127.0.0.1:{port}/ws/live/" for port in stack.web_ports]
            reference = Reference(f"ws://127.0.0.1:{stack.sim_port}")
            reference.start()
            reference.ready.wait(10)
            log.info("scaled: %d clients over two web processes", SCALED)
            pids = [p.pid for p in stack.webs] + [stack.link_proc.pid]
            result = drive(urls, cookie, "watch", SCALED, pids)
            report(f"scaled_{SCALED}", result, reference.stamps)
    finally:
        redis.terminate()
        redis.wait(5)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--clients", type=int)
    parser.add_argument("--mode", choices=["watch", "direct", "idle"])
    parser.add_argument("--url", action="append")
    parser.add_argument("--section", choices=["embedded", "scaled"])
    parser.add_argument("--sizes", type=lambda v: tuple(int(n) for n in v.split(",")), default=SIZES,
                        help="client counts of the embedded section, e.g. 500 (profiling)")
    args = parser.parse_args()
    if args.clients:
        client_main(args)
        return
    logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(message)s")
    if args.section != "scaled":
        embedded_section(args.sizes)
    if args.section != "embedded":
        scaled_section()


if __name__ == "__main__":
    main()
