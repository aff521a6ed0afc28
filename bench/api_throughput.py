"""REST API under load, through the real stack (simulator + Daphne, embedded).

1. ``GET /api/robot/state/`` with a token, 10 connections kept alive, for 20 s:
   ``state_api_rps``, ``state_api_p99_ms`` (and p50), with the server's CPU and the load average.
   The load comes from wrk (C, ``make wrk``) so the client does not measure itself; without wrk,
   from an aiohttp client in this process (``state_api_client`` says which).
2. 200 sequential speech commands, API call → the message's arrival at the simulator (the
   simulator stamps every message it receives with its wall clock; same machine, same clock):
   ``command_to_robot_p50_ms``, ``command_to_robot_p99_ms``; and the API round trip.

Run: ``.venv/bin/python bench/api_throughput.py`` (~40 s; ``--only command`` or ``--only state`` for
one part). Prints ``name: value``.
With ``BENCH_PYSPY=DIR``, py-spy samples the web process over the state API's window (raw folded
stacks, ``DIR/state_api-PID.txt``).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import os
import re
import shutil
import subprocess
import sys
import time
import urllib.parse
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

import aiohttp  # noqa: E402
from _stats import quantile  # noqa: E402
from commands import call  # noqa: E402

from robot import interface as ri  # noqa: E402
from tests.stack import PASSWORD, Stack  # noqa: E402

# The process's capacity, not one caller's allowance: no per-caller limits.
UNTHROTTLED = {"COMMAND_THROTTLE_RATE": "100000/min", "READ_THROTTLE_PER_S": "0"}
log = logging.getLogger("bench.api_throughput")

CONNECTIONS = 10
DURATION_S = 20.0
SPEECH_N = 200


async def hammer(url: str, token: str) -> tuple[int, list[float], int]:
    latencies: list[float] = []
    errors = 0
    deadline = time.monotonic() + DURATION_S
    headers = {"Authorization": f"Token {token}"}

    async def worker(session: aiohttp.ClientSession) -> None:
        nonlocal errors
        while time.monotonic() < deadline:
            t0 = time.perf_counter()
            async with session.get(url, headers=headers) as res:
                await res.read()
                if res.status != 200:
                    errors += 1
                    continue
            latencies.append((time.perf_counter() - t0) * 1000)

    connector = aiohttp.TCPConnector(limit=CONNECTIONS)
    async with aiohttp.ClientSession(connector=connector, timeout=aiohttp.ClientTimeout(total=30)) as session:
        started = time.monotonic()
        await asyncio.gather(*(worker(session) for _ in range(CONNECTIONS)))
        elapsed = time.monotonic() - started
    return round(len(latencies) / elapsed), sorted(latencies), errors


_WRK_TIME = re.compile(r"([\d.]+)(us|ms|s)\b")
_WRK_UNITS = {"us": 0.001, "ms": 1.0, "s": 1000.0}


def wrk_ms(text: str) -> float:
    match = _WRK_TIME.fullmatch(text)
    if not match:
        raise ValueError(f"wrk printed {text!r}")
    return float(match[1]) * _WRK_UNITS[match[2]]


def wrk(url: str, token: str) -> dict[str, float]:
    """wrk's figures: requests/s, p50 and p99 latency (ms), errors (non-2xx and socket errors)."""
    out = subprocess.run(
        ["wrk", "-t", "2", "-c", str(CONNECTIONS), "-d", f"{DURATION_S:.0f}s", "--latency",
         "-H", f"Authorization: Token {token}", url],
        capture_output=True, text=True, timeout=DURATION_S + 60, check=True,
    ).stdout
    figures = {"rps": float(re.search(r"Requests/sec:\s+([\d.]+)", out)[1]),  # type: ignore[index]
               # The distribution's own lines: "99%" also ends stdev shares such as "71.99%".
               "p50": wrk_ms(re.search(r"^\s+50%\s+(\S+)", out, re.M)[1]),  # type: ignore[index]
               "p99": wrk_ms(re.search(r"^\s+99%\s+(\S+)", out, re.M)[1]),  # type: ignore[index]
               "errors": 0.0}
    if non_2xx := re.search(r"Non-2xx or 3xx responses:\s+(\d+)", out):
        figures["errors"] += int(non_2xx[1])
    if socket_errors := re.search(r"Socket errors: connect (\d+), read (\d+), write (\d+), timeout (\d+)", out):
        figures["errors"] += sum(int(n) for n in socket_errors.groups())
    return figures


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def profile(pid: int, name: str) -> subprocess.Popen | None:
    """With BENCH_PYSPY=DIR: py-spy samples ``pid`` over the window (raw folded stacks)."""
    out = os.environ.get("BENCH_PYSPY")
    if not out:
        return None
    Path(out).mkdir(parents=True, exist_ok=True)
    return subprocess.Popen([str(Path(sys.executable).parent / "py-spy"), "record", "--nonblocking", "-p", str(pid),
                             "-d", str(int(DURATION_S)), "-r", "250", "-f", "raw", "-o", f"{out}/{name}-{pid}.txt"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def state_api(stack: Stack, token: str, name: str = "state_api") -> None:
    url = f"{stack.url}/api/robot/state/"
    call_get(url, token)  # outside the window: the first request checks the token against the database
    spy = profile(stack.web.pid, name)
    cpu0, t0 = cpu_seconds(stack.web.pid), time.monotonic()
    if shutil.which("wrk"):
        figures, client = wrk(url, token), "wrk"
    else:
        rps, latencies, errors = asyncio.run(hammer(url, token))
        figures = {"rps": rps, "p50": quantile(latencies, 0.5), "p99": quantile(latencies, 0.99), "errors": errors}
        client = "aiohttp"
    cpu_s = cpu_seconds(stack.web.pid) - cpu0
    cpu = cpu_s / (time.monotonic() - t0) * 100
    if spy is not None:
        spy.wait()
    print(f"{name}_client: {client}")
    print(f"{name}_rps: {figures['rps']:.0f}")
    print(f"{name}_p50_ms: {figures['p50']:.1f}")
    print(f"{name}_p99_ms: {figures['p99']:.1f}")
    print(f"{name}_errors: {figures['errors']:.0f}")
    print(f"{name}_server_cpu_pct: {cpu:.0f}")
    # The server's CPU per request: what the load average does not blur.
    print(f"{name}_server_cpu_ms_per_request: {cpu_s * 1000 / max(1.0, figures['rps'] * DURATION_S):.2f}")
    print(f"{name}_loadavg: {os.getloadavg()[0]:.1f}", flush=True)


def call_get(url: str, token: str) -> dict:
    request = urllib.request.Request(url, headers={"Authorization": f"Token {token}"})
    with urllib.request.urlopen(request, timeout=10) as res:
        return json.loads(res.read())


def received(stack: Stack, topic: str, last: int) -> dict:
    query = urllib.parse.urlencode({"topic": topic, "last": last})
    with urllib.request.urlopen(f"http://127.0.0.1:{stack.video_port}/sim/received?{query}", timeout=5) as res:
        return json.loads(res.read())


def speech_commands(stack: Stack, token: str) -> tuple[list[float], list[float]]:
    topic = ri.topic("text_to_speech").name
    before = received(stack, topic, 0)["count"]
    sent: dict[str, float] = {}
    round_trips = []
    for i in range(SPEECH_N):
        text = f"bench {i}"
        sent[text] = time.time()
        t0 = time.perf_counter()
        call(f"{stack.url}/api/robot/speech/", {"text": text}, token)
        round_trips.append((time.perf_counter() - t0) * 1000)
    deadline = time.monotonic() + 10
    while received(stack, topic, 0)["count"] < before + SPEECH_N and time.monotonic() < deadline:
        time.sleep(0.1)
    arrivals = {m["msg"]["data"]: m["t"] for m in received(stack, topic, SPEECH_N)["messages"]}
    missing = set(sent) - set(arrivals)
    if missing:
        raise SystemExit(f"{len(missing)} speech commands never reached the robot")
    return sorted((arrivals[text] - t) * 1000 for text, t in sent.items()), sorted(round_trips)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", choices=("state", "command"), help="run one part of the bench")
    args = parser.parse_args()
    only = args.only
    logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(message)s")
    with Stack(sim_args=("--startup-s", "0.5"), env=UNTHROTTLED) as stack:
        stack.wait_robot_online()
        token = call(f"{stack.url}/api/auth/token/", {"username": "otto", "password": PASSWORD})["token"]
        if only != "command":
            log.info("state API: %d connections for %.0f s", CONNECTIONS, DURATION_S)
            state_api(stack, token)
        if only == "state":
            return
        log.info("%d sequential speech commands", SPEECH_N)
        cpu0 = cpu_seconds(stack.web.pid)
        to_robot, round_trips = speech_commands(stack, token)
        cpu_ms = (cpu_seconds(stack.web.pid) - cpu0) * 1000 / SPEECH_N
        print(f"command_to_robot_p50_ms: {quantile(to_robot, 0.5):.2f}")
        print(f"command_to_robot_p99_ms: {quantile(to_robot, 0.99):.2f}")
        print(f"command_round_trip_p50_ms: {quantile(round_trips, 0.5):.2f}")
        print(f"command_round_trip_p99_ms: {quantile(round_trips, 0.99):.2f}")
        print(f"command_server_cpu_ms: {cpu_ms:.2f}")
        print(f"command_loadavg: {os.getloadavg()[0]:.1f}", flush=True)


if __name__ == "__main__":
    main()
