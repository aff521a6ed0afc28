"""E-STOP through the real product, measured at the simulated robot.

Embedded stack (simulator + Daphne): an operator drives (W held: input every 50 ms on
``/ws/teleop/``) while another presses E-STOP over the API; from the press to the first zero
Twist and to the motors going off (the simulator's own /rosout stamp), and every non-zero
Twist the robot still receives in the 5 s after the stop's zero while the driver keeps
sending input. Then 20 open pages in headless Chromium: from the press to the banner being
shown on each page. Scaled stack (private redis-server, simulator, Daphne, robotlink): the
web process is SIGKILLed while its driver holds W; from the kill to the zero Twist the link
publishes by itself. The mode race: Behaviour requested, the E-STOP pressed 0.05-0.5 s later,
20 times: every mode event, mode string or emotion-system switch that reached the robot after
the E-STOP's answer and was not the stop's own last message still on the wire. Faults (private
PostgreSQL and Redis, really stopped, frozen and restarted): 50 presses each, ok when answered
within a second with the zero step done and a zero Twist at the robot within 500 ms. Read load
(scaled stack, wrk): a viewer's token polling the state API on 50, then 250 connections, while an
operator presses: the press's answer time. Prints ``name: value`` lines; the machine may be shared.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import signal
import statistics
import sys
import threading
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from websockets.asyncio.client import ClientConnection, connect  # noqa: E402

from bench.teleop_latency import Simulator, login, moving, zero  # noqa: E402
from tests.browser.support import login as page_login  # noqa: E402
from tests.stack import Stack  # noqa: E402
from tests.support_processes import Client, PrivateRedis, Script, online_on_private_postgres, received  # noqa: E402

TRIALS = 10
MOTION_WINDOW_S = 5.0
PAGES = 20
BANNER_TRIALS = 5
KILLS = 3
FORWARD = {"type": "input", "linear": 1.0, "angular": 0.0}
PAGE_PATHS = ["/", "/map/", "/drive/", "/history/", "/activity/"]
CHROMIUM = os.environ.get("CHROMIUM_PATH") or "/usr/bin/chromium"


def p99(values: list[float]) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(0.99 * (len(ordered) - 1)))]


class Api:
    def __init__(self, stack: Stack, cookie: str) -> None:
        self.stack, self.cookie = stack, cookie
        self.csrf = dict(part.split("=", 1) for part in cookie.split("; "))["csrftoken"]

    def post(self, path: str, body: dict | None = None) -> tuple[int, dict]:
        request = urllib.request.Request(
            f"{self.stack.url}{path}", data=json.dumps(body or {}).encode(), method="POST",
            headers={"Cookie": self.cookie, "X-CSRFToken": self.csrf, "Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(request, timeout=15) as res:
                return res.status, json.loads(res.read() or b"{}")
        except urllib.error.HTTPError as err:
            return err.code, json.loads(err.read() or b"{}")

    def release_and_enable(self) -> None:
        status, body = self.post("/api/robot/estop/release/", {"confirm": True})
        assert status == 200, body
        status, body = self.post("/api/robot/motors/", {"enabled": True})
        assert status == 200, body


class Driver:
    """A driver's page that keeps W held: input every 50 ms, like drive.js."""

    def __init__(self, stack: Stack, cookie: str) -> None:
        self.stack, self.cookie = stack, cookie
        self.ws: ClientConnection | None = None
        self._task: asyncio.Task | None = None

    async def start(self, *, reconnect: bool = True) -> None:
        await self._connect()
        self._task = asyncio.ensure_future(self._hold(reconnect))

    async def _connect(self) -> None:
        self.ws = await connect(f"ws://127.0.0.1:{self.stack.web_port}/ws/teleop/", origin=self.stack.url,
                                additional_headers={"Cookie": self.cookie}, compression=None)

    async def _hold(self, reconnect: bool) -> None:
        while True:
            reading = asyncio.ensure_future(self._read())
            with contextlib.suppress(Exception):  # the web process may be killed under us
                while True:
                    await self.ws.send(json.dumps(FORWARD))
                    await asyncio.sleep(0.05)
            reading.cancel()
            if not reconnect:
                return
            await asyncio.sleep(0.2)  # like a page's socket, which reconnects by itself
            with contextlib.suppress(Exception):
                await self._connect()

    async def _read(self) -> None:
        """Read what the server says (lock, refusals) like a page does: unread frames would
        stop the client reading its socket, and its keepalive would then close it."""
        with contextlib.suppress(Exception):
            async for _ in self.ws:
                pass

    async def stop(self) -> None:
        if self._task:
            self._task.cancel()
        with contextlib.suppress(Exception):
            await self.ws.close()


class MotorsWatch:
    """The simulator's own /rosout 'Motors disabled' lines, with their stamps, over rosbridge."""

    def __init__(self, sim_port: int) -> None:
        self.url = f"ws://127.0.0.1:{sim_port}"
        self.disabled_at: list[float] = []

    async def run(self) -> None:
        async with connect(self.url) as ws:
            await ws.send(json.dumps({"op": "subscribe", "topic": "/rosout", "type": "rosgraph_msgs/Log"}))
            async for raw in ws:
                msg = json.loads(raw).get("msg") or {}
                if msg.get("name") == "/RosAria" and msg.get("msg", "").startswith("Motors disabled"):
                    stamp = msg["header"]["stamp"]
                    self.disabled_at.append(stamp["secs"] + stamp["nsecs"] / 1e9)

    def first_after(self, t0: float, timeout: float = 5.0) -> float:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            hits = [t for t in self.disabled_at if t >= t0]
            if hits:
                return hits[0]
            time.sleep(0.01)
        raise SystemExit("the motors never went off")


async def stop_while_driving(stack: Stack) -> dict[str, list[float]]:
    driver_cookie, presser = login(stack, "otto"), Api(stack, login(stack, "olga"))
    sim = Simulator(stack.video_port, "/cmd_vel")
    motors = MotorsWatch(stack.sim_port)
    watching = asyncio.ensure_future(motors.run())
    presser.release_and_enable()
    driver = Driver(stack, driver_cookie)
    await driver.start()
    out: dict[str, list[float]] = {"zero": [], "motors": [], "motion": []}
    try:
        for _ in range(TRIALS):
            before = sim.count()
            await asyncio.to_thread(sim.first_after, before, moving)  # the held key drives again
            before = sim.count()
            t0 = time.time()
            status, body = await asyncio.to_thread(presser.post, "/api/robot/estop/")
            assert status == 200, body
            t_zero = await asyncio.to_thread(sim.first_after, before, zero)
            out["zero"].append((t_zero - t0) * 1000)
            out["motors"].append((await asyncio.to_thread(motors.first_after, t0) - t0) * 1000)
            await asyncio.sleep(max(0.0, t_zero + MOTION_WINDOW_S - time.time()))
            after = sim._get(sim.count() - before)["messages"]
            out["motion"].append(sum(1 for m in after if m["t"] > t_zero and moving(m["msg"])))
            await asyncio.to_thread(presser.release_and_enable)
    finally:
        await driver.stop()
        watching.cancel()
    return out


RACE_RUNS = 20
MODE_TOPICS = ("register_event", "emotional_controller", "robot_mode")


def mode_race(stack: Stack) -> list[int]:
    """Per run, the messages that reached the robot after the E-STOP's answer that the stop did
    not send (anything the latch holds back, or anything later than a message's time on the wire)."""
    from robot import interface as ri

    api = Api(stack, login(stack, "olga"))
    topics = {key: Simulator(stack.video_port, ri.topic(key).name) for key in MODE_TOPICS}
    late: list[int] = []
    for run in range(RACE_RUNS):
        change = threading.Thread(target=api.post, args=("/api/robot/mode/", {"mode": "behaviour"}))
        counts = {key: sim.count() for key, sim in topics.items()}
        change.start()
        time.sleep(0.05 + 0.45 * run / (RACE_RUNS - 1))
        status, body = api.post("/api/robot/estop/")
        answered = time.time()
        assert status == 200, body
        change.join(10)
        time.sleep(0.5)
        after = [(key, m) for key, sim in topics.items()
                 for m in sim._get(sim.count() - counts[key])["messages"] if m["t"] > answered]
        late.append(sum(1 for key, m in after if m["t"] > answered + 0.1
                        or not ri.passes_latch(ri.topic(key).name, m["msg"], by_the_stop=True)))
        api.release_and_enable()
    return late


DB_DOWN_PRESSES = 50


def _press_ok(stack: Stack, page: Client, *, all_steps: bool) -> bool:
    """One press: answered within a second, the zero step reported done (every step, with
    ``all_steps``), and a zero Twist at the robot within 500 ms."""
    from robot import interface as ri

    pressed = time.time()
    try:
        status, body = page.post("/api/robot/estop/", timeout=5)
    except OSError:
        return False
    answered = time.time() - pressed
    steps = {step["step"]: step["ok"] for step in body.get("steps", [])}
    deadline = time.monotonic() + 1.0
    zero = False
    while not zero and time.monotonic() < deadline:
        zero = any(m["t"] >= pressed and m["t"] - pressed <= 0.5 and ri.is_zero_twist(m["msg"])
                   for m in received(stack)[-20:])
        time.sleep(0.02)
    done = status == 200 if all_steps else steps.get("zero_velocity", False)
    return zero and answered <= 1.0 and done


def presses_with_the_database_down() -> list[bool]:
    """Embedded stack on a private PostgreSQL, which is stopped: an operator's page presses the
    E-STOP (and releases it) 50 times; a press is ok when it answers 200 within a second and the
    robot gets a zero Twist within 500 ms of it."""
    results: list[bool] = []
    with online_on_private_postgres() as stack:
        page = Client(stack, "otto")
        stack.postgres.stop()
        for _ in range(DB_DOWN_PRESSES):
            results.append(_press_ok(stack, page, all_steps=True))
            page.post("/api/robot/estop/release/", {"confirm": True})
    return results


REDIS_PRESSES = 50


def presses_with_redis_faults() -> dict[str, list[bool]]:
    """Scaled stack on a private redis-server: 50 presses with Redis stopped, 50 with it frozen
    (SIGSTOP), and 50 each right after a restart (every step must succeed then)."""
    redis = PrivateRedis().start()
    results: dict[str, list[bool]] = {"down": [], "frozen": [], "restart": []}
    try:
        # A short zero hold: the next press's zero is its own, not the last one's hold.
        with Stack(redis_url=redis.url, env={"ESTOP_HOLD_S": "0.1"}) as stack:
            stack.wait_robot_online(timeout=40)
            page = Client(stack, "otto")
            redis.stop()
            time.sleep(3)  # past the link's lease
            results["down"] = [_press_ok(stack, page, all_steps=False) for _ in range(REDIS_PRESSES)]
            redis.start()
            time.sleep(3)
            assert redis.proc is not None
            os.kill(redis.proc.pid, signal.SIGSTOP)
            try:
                time.sleep(3)
                results["frozen"] = [_press_ok(stack, page, all_steps=False) for _ in range(REDIS_PRESSES)]
            finally:
                os.kill(redis.proc.pid, signal.SIGCONT)
            time.sleep(3)
            for _ in range(REDIS_PRESSES):
                page.post("/api/robot/estop/release/", {"confirm": True})
                redis.stop()
                redis.start()
                results["restart"].append(_press_ok(stack, page, all_steps=True))
    finally:
        redis.stop()
    return results


READ_LOAD = ((50, "state_api_50"), (250, "state_api_250"))
LOAD_PRESSES = 20


def presses_under_read_load() -> dict[str, list[float]]:
    """Scaled stack: a viewer's script polls the state API with a token on 50 keep-alive
    connections (wrk), then on 250; meanwhile an operator presses the E-STOP 20 times (and
    releases it): each press's answer time (ms)."""
    import shutil
    import subprocess

    if not shutil.which("wrk"):
        raise SystemExit("wrk is needed for the read load: make wrk")
    redis = PrivateRedis().start()
    results: dict[str, list[float]] = {}
    try:
        with Stack(redis_url=redis.url) as stack:
            stack.wait_robot_online(timeout=40)
            page = Client(stack, "otto")
            viewer = Script(stack, "vera")
            for connections, name in READ_LOAD:
                token = f"Authorization: Token {viewer.token}"
                load = subprocess.Popen(
                    ["wrk", "-t", "2", "-c", str(connections), "-d", "60s", "-H", token,
                     f"{stack.url}/api/robot/state/"],
                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                try:
                    time.sleep(2)
                    answers = []
                    for _ in range(LOAD_PRESSES):
                        pressed = time.perf_counter()
                        status, body = page.post("/api/robot/estop/", timeout=10)
                        answers.append(1000 * (time.perf_counter() - pressed))
                        assert status in (200, 502), body
                        page.post("/api/robot/estop/release/", {"confirm": True})
                        time.sleep(0.2)
                    results[name] = answers
                finally:
                    load.terminate()
                    load.wait(5)
    finally:
        redis.stop()
    return results


def banner_on_all_pages(stack: Stack) -> list[float]:
    from playwright.sync_api import sync_playwright

    from tests.browser.support import CHROMIUM_ARGS

    api = Api(stack, login(stack, "olga"))
    latencies: list[float] = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        context = browser.new_context(viewport={"width": 1280, "height": 800})
        page = context.new_page()
        page_login(page, stack, "otto")
        pages = [page] + [context.new_page() for _ in range(PAGES - 1)]
        for i, each in enumerate(pages):
            if i:
                each.goto(f"{stack.url}{PAGE_PATHS[i % len(PAGE_PATHS)]}")
            each.wait_for_load_state("load")
            each.evaluate("""() => {
                const banner = document.getElementById('estop-banner');
                window.bannerAt = null;
                new MutationObserver(() => {
                    if (!banner.hidden && window.bannerAt === null) window.bannerAt = Date.now();
                }).observe(banner, { attributes: true });
            }""")
        time.sleep(2)  # every page's live socket is open and watching
        for _ in range(BANNER_TRIALS):
            for each in pages:
                each.evaluate("() => { window.bannerAt = null; }")
            t0 = time.time() * 1000
            press = threading.Thread(target=api.post, args=("/api/robot/estop/",))
            press.start()
            for each in pages:
                each.wait_for_function("() => window.bannerAt !== null", timeout=10_000)
                latencies.append(each.evaluate("() => window.bannerAt") - t0)
            press.join()
            api.release_and_enable()
            for each in pages:
                each.wait_for_function("() => document.getElementById('estop-banner').hidden", timeout=10_000)
        browser.close()
    return latencies


async def kill_web_while_driving(stack: Stack) -> list[float]:
    sim = Simulator(stack.video_port, "/cmd_vel")
    cookie = login(stack, "otto")
    Api(stack, cookie).release_and_enable()
    results = []
    for _ in range(KILLS):
        driver = Driver(stack, cookie)
        await driver.start(reconnect=False)
        before = sim.count()
        await asyncio.to_thread(sim.first_after, before, moving)
        await asyncio.sleep(0.5)  # steady driving at the teleop rate
        before = sim.count()
        t0 = time.time()
        os.kill(stack.web.pid, signal.SIGKILL)
        results.append((await asyncio.to_thread(sim.first_after, before, zero) - t0) * 1000)
        await driver.stop()
        stack.web.wait(5)
        stack.start_web()
        stack.wait_robot_online()
        await asyncio.sleep(1.2)  # the dead driver's lock expires
    return results


def main() -> None:
    with Stack() as stack:
        stack.wait_robot_online()
        stopped = asyncio.run(stop_while_driving(stack))
        race = mode_race(stack)
        banners = banner_on_all_pages(stack)
    db_down = presses_with_the_database_down()
    redis_faults = presses_with_redis_faults()
    read_load = presses_under_read_load()
    # The killed process's driver keeps the drive lock until it expires: make that quick.
    redis = PrivateRedis().start()
    try:
        with Stack(redis_url=redis.url, env={"TELEOP_LOCK_TTL_S": "1"}) as stack:
            stack.wait_robot_online(timeout=40)
            kills = asyncio.run(kill_web_while_driving(stack))
    finally:
        redis.stop()
    print(f"estop_to_zero_twist_p99_ms: {p99(stopped['zero']):.1f}")
    print(f"estop_to_zero_twist_p50_ms: {statistics.median(stopped['zero']):.1f}")
    print(f"estop_to_motors_off_p99_ms: {p99(stopped['motors']):.1f}")
    print(f"estop_to_motors_off_p50_ms: {statistics.median(stopped['motors']):.1f}")
    print(f"estop_banner_all_pages_p99_ms: {p99(banners):.1f}")
    print(f"estop_banner_all_pages_p50_ms: {statistics.median(banners):.1f}")
    print(f"motion_after_estop_twists: {sum(stopped['motion'])}")
    print(f"web_kill_to_zero_twist_ms: {max(kills):.1f}")
    print(f"estop_race_events_after_answer: {sum(race)}")
    print(f"estop_db_down_ok_pct: {100 * sum(db_down) / len(db_down):.1f}")
    print(f"estop_db_down_presses: {len(db_down)}")
    print(f"estop_under_read_load_p99_ms: {p99(read_load['state_api_250']):.1f}")
    print(f"estop_under_read_load_50_connections_p99_ms: {p99(read_load['state_api_50']):.1f}")
    for fault, name in (("down", "redis_down"), ("frozen", "redis_frozen"), ("restart", "after_redis_restart")):
        presses = redis_faults[fault]
        print(f"estop_{name}_ok_pct: {100 * sum(presses) / len(presses):.1f}")
    print(f"estop_race_runs: {len(race)}")
    print(f"estop_trials: {len(stopped['zero'])}")
    print(f"estop_banner_samples: {len(banners)}")
    print(f"web_kills: {len(kills)}")


if __name__ == "__main__":
    main()
