"""A soak of the production topology under faults: does the E-STOP hold whatever dies?

scripts/stack.sh (nginx, two Daphne, two robot links, Celery worker and beat, the simulator) on a
private redis-server and a private PostgreSQL. For the whole run (10 minutes; the first argument
gives minutes): an operator drives (W held on the teleop socket through nginx, reconnecting like a
page), changes modes and says a numbered sentence every few seconds; another operator presses the
E-STOP through a random web process every 10 s and releases it 3 s later. Every 20-40 s one fault,
at random: SIGKILL of the active link, SIGKILL of a web process, a Redis restart, a Redis freeze
(SIGSTOP 5 s), PostgreSQL stopped for 8 s, the simulator (the robot) killed, the Celery worker
killed. Processes that die are started again by the stack's keepers, as systemd does; the bench
only ends the faults it made (starts Redis and PostgreSQL again, thaws Redis).

Figures:
  chaos_estop_ok_pct              presses after which the robot got a zero Twist within 500 ms; while
                                  the robot itself was away, a press refused with a clear error counts
  chaos_motion_under_latch_twists moving Twists the robot got between a press's answer and its release
  chaos_unaudited_commands        sentences the robot got with no audit row saying they were sent
  chaos_manual_restarts           product processes the bench found dead and had to start itself
  chaos_faults                    faults injected
and chaos_presses, chaos_failed_presses (each with the fault under way, on stderr), chaos_twists_received
and chaos_sentences_heard (what the checks above looked at).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import random
import signal
import ssl
import sys
import threading
import time
import urllib.parse
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from websockets.asyncio.client import connect  # noqa: E402

from tests.deploy.topology import PrivatePostgres, Topology  # noqa: E402
from tests.support_processes import PrivateRedis  # noqa: E402

PRESS_EVERY_S = 10.0
RELEASE_AFTER_S = 3.0
FAULT_EVERY_S = (20.0, 40.0)
SAY_EVERY_S = 3.0
ZERO_WITHIN_S = 0.5
FAULTS = ("link", "web", "redis_restart", "redis_freeze", "postgres_stop", "robot_restart", "worker")
PROCESSES = ("sim", "link-a", "link-b", "web-a", "web-b", "worker", "beat", "nginx")
MODES = ("idle", "demo", "behaviour", "stop")
SPEECH_TOPIC = "/cyborg_audio/text_to_speech"
_TLS = ssl.create_default_context()
_TLS.check_hostname = False
_TLS.verify_mode = ssl.CERT_NONE


def moving(msg: dict) -> bool:
    return any(abs(msg.get(part, {}).get(axis, 0.0)) > 1e-9 for part in ("linear", "angular") for axis in "xyz")


class SimTap:
    """Everything the simulator receives on some topics, with its receive times, across its restarts."""

    def __init__(self, video_port: int, topics: tuple[str, ...]) -> None:
        self.base = f"http://127.0.0.1:{video_port}/sim/received"
        self.topics = topics
        self.seen: dict[str, list[dict]] = {t: [] for t in topics}
        self._counts = dict.fromkeys(topics, 0)
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _get(self, topic: str, last: int) -> dict:
        query = urllib.parse.urlencode({"topic": topic, "last": last})
        with urllib.request.urlopen(f"{self.base}?{query}", timeout=2) as res:
            return json.loads(res.read())

    def _run(self) -> None:
        while not self._stop.is_set():
            for topic in self.topics:
                with contextlib.suppress(OSError, ValueError):
                    count = self._get(topic, 0)["count"]
                    known = self._counts[topic]
                    fresh = count - known if count >= known else count  # a new simulator counts from 0
                    if fresh > 0:
                        self.seen[topic].extend(self._get(topic, fresh)["messages"][-fresh:])
                    self._counts[topic] = count
            self._stop.wait(0.1)

    def stop(self) -> None:
        self._stop.set()
        self.thread.join(5)


class Operator:
    """An operator's session through nginx (the login form), for the teleop socket."""

    def __init__(self, topo: Topology, username: str) -> None:
        self.origin = topo.url
        self.cookie = topo.login_cookie(username)


async def drive(topo: Topology, operator: Operator, stop: threading.Event) -> None:
    """W held, input every 50 ms; the socket reconnects like a page's when its web process dies."""
    url = topo.url.replace("https://", "wss://") + "/ws/teleop/"
    forward = json.dumps({"type": "input", "linear": 1.0, "angular": 0.0})
    while not stop.is_set():
        with contextlib.suppress(Exception):
            async with connect(url, origin=operator.origin, ssl=_TLS, compression=None,
                               additional_headers={"Cookie": operator.cookie}) as ws:
                reader = asyncio.ensure_future(_drain(ws))
                try:
                    while not stop.is_set():
                        await ws.send(forward)
                        await asyncio.sleep(0.05)
                finally:
                    reader.cancel()
        await asyncio.sleep(0.5)


async def _drain(ws) -> None:
    with contextlib.suppress(Exception):
        async for _ in ws:
            pass


class Chaos:
    def __init__(self, topo: Topology, redis: PrivateRedis, postgres: PrivatePostgres) -> None:
        self.topo, self.redis, self.postgres = topo, redis, postgres
        self.fault = ""  # the fault under way
        self.faults = 0
        self.manual_restarts = 0
        self.presses: list[dict] = []  # {at, answered, status, body, fault, released_at}
        self.said: list[str] = []
        self.stop = threading.Event()

    # --- the operators ---------------------------------------------------------------

    def press_loop(self) -> None:
        while not self.stop.wait(PRESS_EVERY_S):
            press = {"fault": self.fault, "at": time.time()}
            status, body = 0, {}
            for web in random.sample(range(len(self.topo.web_ports)), len(self.topo.web_ports)):
                try:  # the chosen process may just have died: the other one, as nginx would
                    status, body = self.topo.fetch("/api/robot/estop/", web=web, method="POST", user="olga",
                                                   timeout=5)
                    break
                except OSError as exc:
                    body = {"detail": str(exc)}
            press.update(answered=time.time(), status=status, body=body)
            self.presses.append(press)
            self.stop.wait(RELEASE_AFTER_S)
            press["released_at"] = time.time()
            for _ in range(20):
                with contextlib.suppress(OSError):
                    if self.topo.fetch("/api/robot/estop/release/", method="POST", body={"confirm": True},
                                       user="olga")[0] == 200:
                        break
                time.sleep(0.5)

    def command_loop(self) -> None:
        n = 0
        while not self.stop.wait(SAY_EVERY_S):
            n += 1
            text = f"chaos sentence {n}"
            with contextlib.suppress(OSError):
                if self.topo.fetch("/api/robot/speech/", method="POST", body={"text": text}, user="otto")[0] == 200:
                    self.said.append(text)
            with contextlib.suppress(OSError):
                self.topo.fetch("/api/robot/mode/", method="POST", body={"mode": random.choice(MODES)}, user="otto")

    # --- the faults ------------------------------------------------------------------

    def fault_loop(self, end: float) -> None:
        deck: list[str] = []
        while not self.stop.wait(random.uniform(*FAULT_EVERY_S)) and time.time() < end:
            if not deck:  # every kind of fault as often as the others, in a random order
                deck = random.sample(FAULTS, len(FAULTS))
            fault = deck.pop()
            self.fault = fault
            self.faults += 1
            print(f"{time.strftime('%H:%M:%S')} fault: {fault}", file=sys.stderr, flush=True)
            try:
                getattr(self, f"_{fault}")()
            finally:
                self.fault = ""
            self.check_processes()

    def _link(self) -> None:
        active = self.topo.active_link()
        if active:
            self.topo.crash(active)
        time.sleep(5)

    def _web(self) -> None:
        self.topo.crash(random.choice(("web-a", "web-b")))
        time.sleep(5)

    def _redis_restart(self) -> None:
        self.redis.stop()
        time.sleep(3)
        self.redis.start()
        time.sleep(3)

    def _redis_freeze(self) -> None:
        assert self.redis.proc is not None
        os.kill(self.redis.proc.pid, signal.SIGSTOP)
        try:
            time.sleep(5)
        finally:
            os.kill(self.redis.proc.pid, signal.SIGCONT)
        time.sleep(3)

    def _postgres_stop(self) -> None:
        self.postgres.stop()
        time.sleep(8)
        self.postgres.start()
        time.sleep(3)

    def _robot_restart(self) -> None:
        self.topo.crash("sim")
        time.sleep(6)

    def _worker(self) -> None:
        self.topo.crash("worker")
        time.sleep(5)

    def check_processes(self) -> None:
        """Every process of the stack running (its keeper started it again), or started by hand and counted."""
        for name in PROCESSES:
            if not self.topo.alive(name):
                print(f"{name} is dead: starting it by hand", file=sys.stderr, flush=True)
                self.manual_restarts += 1
                self.topo.script(f"restart {name}")


def press_ok(press: dict, twists: list[dict]) -> bool:
    zero = any(press["at"] <= m["t"] <= press["at"] + ZERO_WITHIN_S and not moving(m["msg"]) for m in twists)
    if zero:
        return True
    steps = {s.get("step"): s for s in press["body"].get("steps", [])}
    robot_away = press["fault"] == "robot_restart" and "offline" in str(steps.get("zero_velocity", {}).get("detail"))
    return robot_away and press["status"] == 502


def motion_under_latch(presses: list[dict], twists: list[dict]) -> int:
    return sum(1 for p in presses if "released_at" in p for m in twists
               if p["answered"] < m["t"] < p["released_at"] and moving(m["msg"]))


def unaudited(topo: Topology, heard: list[dict]) -> int:
    texts = {m["msg"].get("data") for m in heard if str(m["msg"].get("data", "")).startswith("chaos sentence")}
    audited: set[str] = set()
    page = 1
    while True:
        status, body = topo.fetch(f"/api/audit/?action=speech&outcome=ok&page_size=500&page={page}", user="ada")
        audited.update(str(r["params"].get("text")) for r in body.get("results", []))
        if status != 200 or not body.get("next"):
            break
        page += 1
    return len(texts - audited)


def main() -> None:
    minutes = float(sys.argv[1]) if len(sys.argv) > 1 else 10.0
    redis, postgres = PrivateRedis().start(), PrivatePostgres().start()
    topo = Topology(redis_url=redis.url, database_url=postgres.url, env={"COMMAND_THROTTLE_RATE": "2000/min"})
    tap = None
    try:
        topo.up()
        tap = SimTap(int(topo.env["STACK_VIDEO_PORT"]), ("/cmd_vel", SPEECH_TOPIC))
        tap.thread.start()
        chaos = Chaos(topo, redis, postgres)
        operator = Operator(topo, "otto")
        end = time.time() + 60 * minutes
        driving = threading.Thread(target=lambda: asyncio.run(drive(topo, operator, chaos.stop)), daemon=True)
        loops = [threading.Thread(target=chaos.press_loop, daemon=True),
                 threading.Thread(target=chaos.command_loop, daemon=True), driving]
        for loop in loops:
            loop.start()
        chaos.fault_loop(end)
        while time.time() < end:
            time.sleep(1)
        chaos.stop.set()
        for loop in loops:
            loop.join(30)
        time.sleep(3)  # the last sentences reach the robot and the audit
        tap.stop()
        twists = tap.seen["/cmd_vel"]
        ok = [press_ok(p, twists) for p in chaos.presses]
        for press, fine in zip(chaos.presses, ok, strict=True):
            if not fine:
                print(f"press at {press['at']:.1f} during {press['fault'] or 'no fault'} failed: {press['status']} "
                      f"{json.dumps(press['body'])[:400]}", file=sys.stderr)
        print(f"chaos_estop_ok_pct: {100 * sum(ok) / max(1, len(ok)):.1f}")
        print(f"chaos_motion_under_latch_twists: {motion_under_latch(chaos.presses, twists)}")
        print(f"chaos_unaudited_commands: {unaudited(topo, tap.seen[SPEECH_TOPIC])}")
        print(f"chaos_manual_restarts: {chaos.manual_restarts}")
        print(f"chaos_faults: {chaos.faults}")
        print(f"chaos_presses: {len(ok)}")
        print(f"chaos_twists_received: {len(twists)}")
        print(f"chaos_sentences_heard: {sum(1 for m in tap.seen[SPEECH_TOPIC] if 'chaos' in str(m['msg']))}")
        print(f"chaos_failed_presses: {len(ok) - sum(ok)}")
    finally:
        if tap is not None:
            tap.stop()
        try:
            topo.down()
        finally:
            redis.stop()
            postgres.remove()


if __name__ == "__main__":
    main()
