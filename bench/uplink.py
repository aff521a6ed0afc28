"""The robot dials out: latencies and costs of the uplink, as real processes across a real boundary.

The simulator and the uplink agent (on the oldest Python here) run in a network namespace the
server cannot reach; the agent dials nginx (TLS, a test CA) through a latency relay of our own
(40 ms each way, 10 ms jitter; no kernel netem on this machine) and the server (Daphne, embedded
link) drives the robot through it. The operator is a real headless Chromium on the drive page,
through the same nginx (TLS) as the robot: a key press (its keydown event's time in the page) to the
Twist at the robot, and the robot's odometry (its stamp, taken when the simulator publishes it) to
the page's readout showing it. Receive times are the simulator's wall clock; the page's are
``Date.now()``: one machine, one clock. The ``socket`` figures drive the server's sockets from Python
instead (what the server and the uplink take, without a browser). Needs root (ip netns).
Usage: ``.venv/bin/python bench/uplink.py``. Prints ``name: value`` lines.
"""

from __future__ import annotations

import asyncio
import json
import os
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))
os.environ.setdefault("DJANGO_SETTINGS_MODULE", "cyborg_site.settings")

from _stats import quantile  # noqa: E402
from playwright.sync_api import Page, expect, sync_playwright  # noqa: E402
from websockets.asyncio.client import connect  # noqa: E402
from websockets.typing import Origin  # noqa: E402

from tests.browser.support import CHROMIUM, CHROMIUM_ARGS  # noqa: E402
from tests.helpers import run_coroutine  # noqa: E402
from tests.stack import PASSWORD, PYTHON, Stack, free_port  # noqa: E402
from tests.support_processes import Client  # noqa: E402
from tests.uplink.netns import Front, RobotSide, TestCA  # noqa: E402
from tests.uplink.relay import LatencyRelay  # noqa: E402
from tests.uplink.support import Agent  # noqa: E402

DELAY_S, JITTER_S = 0.040, 0.010
PRESSES = 100  # enough that the p99 is not simply the slowest press
UPDATES_S = 15.0
VIEWERS = 20
CPU_S = 10.0
FORWARD = {"type": "input", "linear": 0.3, "angular": 0.0}


class World:
    def __init__(self) -> None:
        self.side = RobotSide().up()
        self.ca = TestCA(self.side.host_ip)
        self.sim_port, self.video_port = free_port(), free_port()
        uplink_port, relay_port, video_relay_port = free_port(), free_port(), free_port()
        self.stack = Stack(sim=False, env={
            "UPLINK": "true", "UPLINK_LISTEN": f"127.0.0.1:{uplink_port}",
            "UPLINK_ROSBRIDGE_PORT": str(relay_port), "UPLINK_VIDEO_PORT": str(video_relay_port),
            "ROSBRIDGE_URL": f"ws://127.0.0.1:{relay_port}", "VIDEO_URL": f"http://127.0.0.1:{video_relay_port}",
            "TRUSTED_PROXIES": "127.0.0.1", "CAMERA_STREAMS_PER_PERSON": str(VIEWERS)})
        self.front = Front(ip=self.side.host_ip, port=free_port(), uplink_port=uplink_port, ca=self.ca,
                           web_port=self.stack.web_port)
        self.stack.env.update(self.front.web_env())
        self.stack.start()
        self.sim = self.side.spawn([PYTHON, "-m", "simulator", "--host", "127.0.0.1", "--port",
                                    str(self.sim_port), "--video-port", str(self.video_port), "--startup-s", "0.5"],
                                   self.stack.tmp / "sim.log", self.stack.env)
        self.side.wait_port(self.sim_port)
        self.front.start()
        self.relay = LatencyRelay((self.side.host_ip, free_port()), (self.side.host_ip, self.front.port),
                                  delay_s=DELAY_S, jitter_s=JITTER_S)
        code = "from robot.uplink.credentials import credential_create\nprint(credential_create(robot='cyborg')[1])"
        credential = self.stack.manage("shell", "-c", code).strip().splitlines()[-1]
        self.agent = Agent(server_url=f"wss://{self.side.host_ip}:{self.relay.listen[1]}/uplink/",
                           credential=credential, rosbridge_url=f"ws://127.0.0.1:{self.sim_port}",
                           video_url=f"http://127.0.0.1:{self.video_port}", prefix=self.side.prefix(),
                           UPLINK_CA_FILE=str(self.ca.ca), UPLINK_LOG_LEVEL="WARNING").start()
        self.operator = Client(self.stack, "otto")
        self.wait_commands()

    def sim_get(self, path: str) -> dict:
        return json.loads(self.side.fetch(f"http://127.0.0.1:{self.video_port}{path}"))

    def twists_after(self, count: int) -> list[dict]:
        total = self.sim_get("/sim/received?topic=/cmd_vel&last=0")["count"]
        if total <= count:
            return []
        return self.sim_get(f"/sim/received?topic=/cmd_vel&last={total - count}")["messages"]

    def twist_count(self) -> int:
        return self.sim_get("/sim/received?topic=/cmd_vel&last=0")["count"]

    def first_twist(self, count: int, moving: bool, timeout: float = 5.0) -> float:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            hits = [m["t"] for m in self.twists_after(count) if (m["msg"]["linear"]["x"] != 0) == moving]
            if hits:
                return hits[0]
            time.sleep(0.02)
        raise SystemExit(f"no {'moving' if moving else 'zero'} Twist reached the robot")

    def wait_commands(self, timeout: float = 40.0) -> float:
        """Until a command works (the speech API answers 200); the seconds it took."""
        start = time.monotonic()
        while time.monotonic() - start < timeout:
            if self.operator.post("/api/robot/speech/", {"text": "ok"}, timeout=5)[0] == 200:
                return time.monotonic() - start
            time.sleep(0.05)
        raise SystemExit(f"commands never worked through the uplink:\n{self.agent.log()[-2000:]}")

    def stop(self) -> None:
        self.agent.__exit__()
        self.front.stop()
        os.killpg(self.sim.pid, 15)
        self.sim.wait(10)
        self.stack.stop()
        self.ca.remove()
        self.side.down()


async def socket_key_to_twist(world: World) -> list[float]:
    """A teleop socket of our own: its input frame sent to the first moving Twist at the robot."""
    out = []
    # (It never reads what the socket says: an unbounded queue keeps the client reading, pongs included.)
    async with connect(f"ws://127.0.0.1:{world.stack.web_port}/ws/teleop/", origin=Origin(world.stack.url),
                       additional_headers={"Cookie": world.operator.cookie}, max_queue=None) as ws:
        for i in range(PRESSES + 1):
            before = await asyncio.to_thread(world.twist_count)
            sent = time.time()
            await ws.send(json.dumps(FORWARD))
            got = await asyncio.to_thread(world.first_twist, before, True)
            await ws.send(json.dumps({"type": "release"}))
            await asyncio.to_thread(world.first_twist, before, False)
            await asyncio.sleep(0.3)
            if i:  # the first press also takes the drive lock
                out.append((got - sent) * 1000)
    return out


async def update_to_socket(world: World, seconds: float = 6.0) -> list[float]:
    """A live socket of our own: the odometry's stamp to its frame arriving."""
    out: list[float] = []
    async with connect(f"ws://127.0.0.1:{world.stack.web_port}/ws/live/", origin=Origin(world.stack.url),
                       additional_headers={"Cookie": world.operator.cookie}, max_size=None) as ws:
        await ws.send(json.dumps({"action": "watch", "keys": ["odom"]}))
        end = time.time() + seconds
        while time.time() < end:
            raw = await ws.recv()
            now = time.time()
            frame = json.loads(raw)
            for update in frame.get("updates") or ([frame] if frame.get("kind") == "update" else []):
                if update.get("key") == "odom":
                    stamp = update["msg"]["header"]["stamp"]
                    out.append((now - stamp["secs"] - stamp["nsecs"] / 1e9) * 1000)
    return out[10:]  # (the snapshot on watching, and the first frames)


# The page's own record: each key event's time, and for each odometry update its stamp, when the live
# socket delivered it and when the drive page's readout (#odom-vel) took it (the page updates the
# readout in the same task; the observer runs right after).
PAGE_HOOKS = """
window.__bench = {keys: [], sends: [], odom: [], pending: null};
for (const type of ["keydown", "keyup"]) {
  window.addEventListener(type, (ev) => {
    if (!ev.repeat) window.__bench.keys.push([type, ev.key, Date.now()]);
  }, true);
}
const NativeSocket = window.WebSocket;
window.WebSocket = class extends NativeSocket {
  constructor(url, protocols) {
    super(url, protocols);
    this.benchTeleop = String(url).includes("/ws/teleop/");
    if (!String(url).includes("/ws/live/")) return;
    this.addEventListener("message", (ev) => {
      const at = Date.now(), frame = JSON.parse(ev.data);
      const updates = frame.kind === "updates" ? frame.updates : frame.kind === "update" ? [frame] : [];
      for (const u of updates) {
        const stamp = u.key === "odom" && u.msg.header.stamp;
        if (stamp) window.__bench.pending = [stamp.secs * 1000 + stamp.nsecs / 1e6, at];
      }
    });
  }
  send(data) {
    if (this.benchTeleop && String(data).includes('"input"')) window.__bench.sends.push(Date.now());
    super.send(data);
  }
};
document.addEventListener("DOMContentLoaded", () => {
  const readout = document.getElementById("odom-vel");
  if (!readout) return;
  new MutationObserver(() => {
    const pending = window.__bench.pending;
    if (pending) window.__bench.odom.push([...pending, Date.now()]);
    window.__bench.pending = null;
  }).observe(readout, {attributes: true, attributeFilter: ["data-linear"]});
});
"""


def open_drive_page(world: World, page: Page) -> None:
    """An operator on the drive page, through nginx over TLS, holding the drive lock."""
    site = world.front.web_url
    page.add_init_script(PAGE_HOOKS)
    page.goto(f"{site}/accounts/login/?next=/drive/")
    page.fill("input[name=username]", "olga")
    page.fill("input[name=password]", PASSWORD)
    page.click("button[type=submit]")
    page.wait_for_url(f"{site}/drive/")
    take_drive(page)


def take_drive(page: Page) -> None:
    expect(page.locator("#lock-state")).to_have_text("Nobody is driving", timeout=30_000)
    page.click("#lock-acquire")
    expect(page.locator("#lock-state")).to_have_text("You are driving")


def release_drive(page: Page) -> None:
    page.click("#lock-release")
    expect(page.locator("#lock-state")).to_have_text("Nobody is driving")


def browser_key_to_twist(world: World, page: Page) -> list[tuple[float, float]]:
    """The browser's key press (its keydown event in the page) to the first moving Twist at the robot,
    and of that the part in the page (keydown to its teleop socket's send)."""
    out = []
    for i in range(PRESSES + 1):
        before = world.twist_count()
        page.keyboard.down("w")
        pressed_ms, sent_ms = page.evaluate(
            "() => { const down = window.__bench.keys.filter(([t]) => t === 'keydown').at(-1)[2];"
            " return [down, window.__bench.sends.find((t) => t >= down)]; }")
        got = world.first_twist(before, True)
        page.keyboard.up("w")
        world.first_twist(before, False)
        time.sleep(0.3)  # (a pause between presses, as a driver's hands make)
        if i:  # (the first press warms the page's path)
            out.append((got * 1000 - pressed_ms, sent_ms - pressed_ms))
    return out


def browser_update_to_page(page: Page, seconds: float = UPDATES_S) -> tuple[list[float], list[float]]:
    """The robot's odometry (its stamp) to the page: its live socket delivering it, and its readout showing it."""
    page.evaluate("() => { window.__bench.odom = []; }")
    time.sleep(seconds)  # (collecting: the robot publishes at 10 Hz meanwhile)
    records = page.evaluate("() => window.__bench.odom")[5:]
    return [at - stamp for stamp, at, _ in records], [shown - stamp for stamp, _, shown in records]


async def stall_to_zero(world: World) -> float:
    # (It never reads what the socket says: an unbounded queue keeps the client reading, pongs included.)
    async with connect(f"ws://127.0.0.1:{world.stack.web_port}/ws/teleop/", origin=Origin(world.stack.url),
                       additional_headers={"Cookie": world.operator.cookie}, max_queue=None) as ws:
        before = await asyncio.to_thread(world.twist_count)
        for _ in range(10):
            await ws.send(json.dumps(FORWARD))
            await asyncio.sleep(0.05)
        await asyncio.to_thread(world.first_twist, before, True)
        count = await asyncio.to_thread(world.twist_count)
        world.relay.frozen = True
        frozen_at = time.time()
        for _ in range(20):  # the driver keeps pressing: the server cannot reach the robot
            await ws.send(json.dumps(FORWARD))
            await asyncio.sleep(0.05)
        zero_at = await asyncio.to_thread(world.first_twist, count, False)
    world.relay.cut()  # (what the relay held is dropped, as a dead link would)
    world.relay.frozen = False
    return (zero_at - frozen_at) * 1000


def video_streams(world: World) -> tuple[int, int]:
    """The robot's video server's open streams: before the viewers come (the camera recorder's, at its
    own size) and what the viewers add."""
    deadline = time.monotonic() + 10  # the recorder dials again within seconds of a reconnect
    while (before := int(world.sim_get("/sim/introspect")["video_streams"])) < 1 and time.monotonic() < deadline:
        time.sleep(0.1)
    return before, _viewers_streams(world) - before


def _viewers_streams(world: World) -> int:
    request = urllib.request.Request(f"{world.stack.url}/video/stream", headers={"Cookie": world.operator.cookie})
    deadline = time.monotonic() + 10

    def watch() -> Any:
        """One viewer; a 503 (the camera not yet back through a reconnected uplink) is tried again until then."""
        while True:
            try:
                return urllib.request.urlopen(request, timeout=10)
            except urllib.error.HTTPError as exc:
                if exc.code != 503 or time.monotonic() > deadline:
                    raise
            time.sleep(0.1)

    viewers = [watch() for _ in range(VIEWERS)]
    try:
        for viewer in viewers:
            seen = b""
            while seen.count(b"--boundarydonotcross") < 2:
                seen += viewer.read1(65536)
        return int(world.sim_get("/sim/introspect")["video_streams"])
    finally:
        for viewer in viewers:
            viewer.close()


def agent_cpu_pct(world: World, seconds: float = CPU_S) -> float:
    """The agent's CPU over ``seconds`` while the link holds every monitored topic (the robot's load)."""
    assert world.agent.proc is not None
    pid, ticks = world.agent.proc.pid, os.sysconf("SC_CLK_TCK")

    def used() -> float:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / ticks

    start, at = used(), time.monotonic()
    time.sleep(seconds)
    return (used() - start) / (time.monotonic() - at) * 100


def _p(values: list[float], q: float) -> float:
    return quantile(sorted(values), q)


def main() -> None:
    if os.geteuid() != 0:
        raise SystemExit("bench/uplink.py needs root (a network namespace for the robot's side)")
    if not os.path.exists(CHROMIUM):
        raise SystemExit(f"Chromium not found at {CHROMIUM}: run `make browser`")
    world = World()
    try:
        cpu = agent_cpu_pct(world)
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            context = browser.new_context(ignore_https_errors=True, viewport={"width": 1280, "height": 900})
            page = context.new_page()
            page.set_default_timeout(15_000)
            try:
                world.relay.delay_s, world.relay.jitter_s = 0.0, 0.0
                open_drive_page(world, page)
                no_delay = browser_key_to_twist(world, page)
                release_drive(page)
                socket_no_delay = run_coroutine(socket_key_to_twist(world))
                world.relay.delay_s, world.relay.jitter_s = DELAY_S, JITTER_S
                world.relay.cut()
                world.wait_commands()
                socket_delayed = run_coroutine(socket_key_to_twist(world))
                take_drive(page)
                delayed = browser_key_to_twist(world, page)
                release_drive(page)
                to_socket, to_readout = browser_update_to_page(page)
            finally:
                context.close()
                browser.close()
        socket_updates = run_coroutine(update_to_socket(world))
        stall = run_coroutine(stall_to_zero(world))
        reconnect = world.wait_commands()
        time.sleep(1)
        world.relay.cut()
        reconnect = max(reconnect, world.wait_commands())
        streams = video_streams(world)
    finally:
        world.stop()
    for suffix, presses in (("", delayed), ("_no_delay", no_delay)):
        totals = [total for total, _ in presses]
        worst = max(presses)
        print(f"uplink_key_to_twist_p99_ms{suffix}: {_p(totals, 0.99):.1f}")
        print(f"uplink_key_to_twist_p50_ms{suffix}: {_p(totals, 0.5):.1f}")
        # Where the slowest press's time went: the page (keydown to its socket's send), then the rest.
        print(f"uplink_key_to_twist_worst_ms{suffix}: {worst[0]:.1f} (page {worst[1]:.1f}, "
              f"server and uplink {worst[0] - worst[1]:.1f})")
    print(f"uplink_update_to_browser_p99_ms: {_p(to_readout, 0.99):.1f} ({len(to_readout)} updates)")
    print(f"uplink_update_to_browser_p50_ms: {_p(to_readout, 0.5):.1f}")
    print(f"uplink_update_to_browser_socket_p99_ms: {_p(to_socket, 0.99):.1f}")
    print(f"uplink_socket_key_to_twist_p99_ms: {_p(socket_delayed, 0.99):.1f}")
    print(f"uplink_socket_key_to_twist_p50_ms: {_p(socket_delayed, 0.5):.1f}")
    print(f"uplink_socket_key_to_twist_p99_ms_no_delay: {_p(socket_no_delay, 0.99):.1f}")
    print(f"uplink_update_to_socket_p99_ms: {_p(socket_updates, 0.99):.1f}")
    print(f"uplink_update_to_socket_p50_ms: {_p(socket_updates, 0.5):.1f}")
    print(f"uplink_stall_to_zero_twist_ms: {stall:.0f}")
    print(f"uplink_reconnect_s: {reconnect:.2f}")
    print(f"uplink_video_upstream_streams: {streams[1]} (for {VIEWERS} viewers)")
    print(f"uplink_video_recorder_streams: {streams[0]} (the camera recorder's own, at its size)")
    print(f"uplink_agent_cpu_pct: {cpu:.1f}")
    print(f"uplink_injected_delay_ms: {DELAY_S * 1000:.0f} each way, jitter {JITTER_S * 1000:.0f}")


if __name__ == "__main__":
    main()
