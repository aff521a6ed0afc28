"""Command latency through the real stack: REST call → robot, and mode request → state reached.

Run: .venv/bin/python bench/commands.py  (starts its own simulator + Daphne, ~30 s)
"""

from __future__ import annotations

import json
import statistics
import sys
import time
import urllib.request
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from tests.stack import PASSWORD, Stack

SPEECH_N = 200
# The process's capacity, not one caller's allowance: no per-caller limits.
UNTHROTTLED = {"COMMAND_THROTTLE_RATE": "100000/min", "READ_THROTTLE_PER_S": "0"}
MODE_N = 10


def call(url: str, body: dict | None = None, token: str = "") -> dict:
    data = json.dumps(body).encode() if body is not None else None
    req = urllib.request.Request(url, data=data, headers={"Content-Type": "application/json",
                                                         **({"Authorization": f"Token {token}"} if token else {})})
    with urllib.request.urlopen(req, timeout=10) as res:
        return json.loads(res.read())


def pct(values: list[float], p: float) -> float:
    return sorted(values)[min(len(values) - 1, int(len(values) * p))]


def main() -> None:
    with Stack(sim_args=("--startup-s", "0.5"), env=UNTHROTTLED) as stack:
        stack.wait_robot_online()
        token = call(f"{stack.url}/api/auth/token/", {"username": "otto", "password": PASSWORD})["token"]
        speech = []
        for i in range(SPEECH_N):
            t0 = time.perf_counter()
            call(f"{stack.url}/api/robot/speech/", {"text": f"bench {i}"}, token)
            speech.append((time.perf_counter() - t0) * 1000)
        reach = []
        for i in range(MODE_N):
            mode, state = ("manual", "manual") if i % 2 == 0 else ("stop", "suspension")
            t0 = time.perf_counter()
            call(f"{stack.url}/api/robot/mode/", {"mode": mode}, token)
            while True:
                current = call(f"{stack.url}/api/robot/state/", token=token)["mode"]
                if current and current["mode"] == mode and current["reached"] and current["state"] == state:
                    break
                time.sleep(0.005)
            reach.append((time.perf_counter() - t0) * 1000)
    print(f"speech_command_p50_ms: {statistics.median(speech):.1f}")
    print(f"speech_command_p99_ms: {pct(speech, 0.99):.1f}")
    print(f"mode_request_to_state_p50_ms: {statistics.median(reach):.1f}")
    print(f"mode_request_to_state_max_ms: {max(reach):.1f}")


if __name__ == "__main__":
    main()
