"""The robot behind a real network boundary: the simulator and the agent in a network namespace of
their own, which the server cannot reach; the agent dials nginx (TLS, the tests' own CA) and the
server drives the robot through it. Each test leaves the topology as it found it."""

from __future__ import annotations

import asyncio
import json
import os
import re
import socket
import subprocess
import time
import urllib.request
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import pytest
from django.conf import settings
from playwright.sync_api import Browser, Page, expect
from websockets.asyncio.client import connect
from websockets.typing import Origin

from tests.helpers import run_coroutine, wait_until
from tests.stack import PASSWORD, PYTHON, Stack, free_port
from tests.support_processes import Client, PrivateRedis
from tests.uplink.netns import Front, RobotSide, TestCA
from tests.uplink.support import Agent

pytestmark = [pytest.mark.stack, pytest.mark.skipif(os.geteuid() != 0, reason="network namespaces need root")]
FORWARD = {"type": "input", "linear": 0.3, "angular": 0.0}


@dataclass
class World:
    side: RobotSide
    stack: Stack
    front: Front
    agent: Agent
    sim_port: int
    video_port: int
    clients: dict[str, Client] = field(default_factory=dict)

    def received(self, topic: str = "/cmd_vel") -> list[dict]:
        url = f"http://127.0.0.1:{self.video_port}/sim/received?topic={topic}"
        count = json.loads(self.side.fetch(f"{url}&last=0"))["count"]
        return json.loads(self.side.fetch(f"{url}&last={max(count, 1)}"))["messages"]

    def client(self, name: str) -> Client:
        """One login per person and world (a login hashes a password: slow on purpose)."""
        if name not in self.clients:
            self.clients[name] = Client(self.stack, name)
        return self.clients[name]

    def health(self) -> dict:
        status, body = self.client("ada").get("/healthz")
        assert status in (200, 503), body
        return body

    def uplinked(self) -> bool:
        body = self.health()
        return bool(body.get("connected") and (body.get("uplink") or {}).get("connected"))

    def wait_online(self, timeout: float = 20) -> None:
        try:
            wait_until(self.uplinked, timeout=timeout)
        except AssertionError:
            raise AssertionError(f"the robot never came online through its uplink: {self.health()}\n"
                                 f"{self.agent.log()[-2000:]}") from None

    def credential(self, *, revoke: str = "") -> str:
        """A new credential's text (or revoke the credential with key id ``revoke``)."""
        code = ("from robot.models import UplinkCredential\nfrom robot.uplink.credentials import *\n" + (
            f"credential_revoke(credential=UplinkCredential.objects.get(key_id={revoke!r}))\n" if revoke else
            "print(credential_create(robot='cyborg', label='netns')[1])\n"))
        out = self.stack.manage("shell", "-c", code).strip()
        return out.splitlines()[-1] if not revoke else ""


def _unreachable(host: str, port: int) -> bool:
    try:
        socket.create_connection((host, port), 1).close()
    except OSError:
        return True
    return False


@pytest.fixture(scope="module")
def world() -> Iterator[World]:
    side = RobotSide().up()
    ca = TestCA(side.host_ip)
    redis = None if settings.EMBEDDED else PrivateRedis().start()
    sim_port, video_port = free_port(), free_port()
    uplink_port, relay_port, relay_video_port = free_port(), free_port(), free_port()
    stack = Stack(sim=False, redis_url=redis.url if redis else None, env={
        "UPLINK": "true", "UPLINK_LISTEN": f"127.0.0.1:{uplink_port}",
        "UPLINK_ROSBRIDGE_PORT": str(relay_port), "UPLINK_VIDEO_PORT": str(relay_video_port),
        "ROSBRIDGE_URL": f"ws://127.0.0.1:{relay_port}", "VIDEO_URL": f"http://127.0.0.1:{relay_video_port}",
        "TRUSTED_PROXIES": "127.0.0.1", "TELEOP_LOCK_TTL_S": "1", "CAMERA_RECORD_FPS": "0"})
    # The browsers' way in too: the same nginx carries the site's pages and sockets (TLS, the test CA).
    front = Front(ip=side.host_ip, port=free_port(), uplink_port=uplink_port, ca=ca, web_port=stack.web_port)
    stack.env.update(front.web_env())
    agent = None
    sim = None
    try:
        stack.start()
        sim = side.spawn([PYTHON, "-m", "simulator", "--host", "127.0.0.1", "--port", str(sim_port),
                          "--video-port", str(video_port), "--startup-s", "0.5"], stack.tmp / "sim.log", stack.env)
        side.wait_port(sim_port)
        # The boundary holds: nothing of the robot's is reachable from the server's side.
        assert _unreachable(side.robot_ip, sim_port) and _unreachable(side.robot_ip, video_port)
        assert _unreachable("127.0.0.1", sim_port) and _unreachable("127.0.0.1", video_port)
        front.start()
        world = World(side, stack, front, None, sim_port, video_port)  # type: ignore[arg-type]
        agent = world.agent = Agent(
            server_url=f"wss://{side.host_ip}:{front.port}/uplink/", credential=world.credential(),
            rosbridge_url=f"ws://127.0.0.1:{sim_port}", video_url=f"http://127.0.0.1:{video_port}",
            prefix=side.prefix(), UPLINK_CA_FILE=str(ca.ca)).start()
        world.wait_online(timeout=40)
        assert world.client("otto").post("/api/robot/motors/", {"enabled": True})[0] == 200
        yield world
    finally:
        if agent is not None:
            agent.__exit__()
        front.stop()
        if sim is not None:
            os.killpg(sim.pid, 15)
            sim.wait(10)
        stack.stop()
        if redis is not None:
            redis.stop()
        ca.remove()
        side.down()


def test_the_dashboard_shows_the_robot_through_its_uplink_and_a_command_reaches_it(world: World) -> None:
    body = world.health()
    assert body["uplink"]["address"] == world.side.robot_ip  # as nginx saw it, through TRUSTED_PROXIES
    assert body["reached"].startswith(f"robot connected through its uplink from {world.side.robot_ip} since ")
    before = len(world.received("/cyborg_audio/text_to_speech"))
    status, reply = world.client("otto").post("/api/robot/speech/", {"text": "hello through the uplink"})
    assert status == 200, reply
    wait_until(lambda: len(world.received("/cyborg_audio/text_to_speech")) > before, timeout=5,
               what="the robot said it")
    assert world.received("/cyborg_audio/text_to_speech")[-1]["msg"]["data"] == "hello through the uplink"


def _pose(page: Page) -> tuple[float, float]:
    x, y = page.locator("#pose").evaluate("el => [el.dataset.x, el.dataset.y]")
    return float(x), float(y)


def test_a_browser_through_nginx_sees_the_robot_live_through_its_uplink_and_drives_it_with_the_keyboard(
        world: World, browser: Browser) -> None:
    """Headless Chromium over TLS through the same nginx the robot dials: the dashboard says where the
    robot is connected from, and the drive page's keys reach the robot's /cmd_vel in the namespace."""
    context = browser.new_context(ignore_https_errors=True, viewport={"width": 1280, "height": 900})
    page = context.new_page()
    page.set_default_timeout(15_000)
    errors: list[str] = []
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    site = world.front.web_url
    try:
        page.goto(f"{site}/accounts/login/?next=/")
        page.fill("input[name=username]", "olga")
        page.fill("input[name=password]", PASSWORD)
        page.click("button[type=submit]")
        page.wait_for_url(f"{site}/")
        expect(page.locator('[data-field="link.state"]')).to_have_text("Robot online")
        expect(page.locator('[data-field="link.url"]')).to_have_text(
            re.compile(f"^robot connected through its uplink from {re.escape(world.side.robot_ip)} since "))

        page.goto(f"{site}/drive/")
        expect(page.locator("#motors")).to_have_text("enabled")
        expect(page.locator("#pose")).not_to_have_attribute("data-x", "")
        expect(page.locator("#lock-state")).to_have_text("Nobody is driving")  # (another test's lock lapsed)
        page.click("#lock-acquire")
        expect(page.locator("#lock-state")).to_have_text("You are driving")
        start = _pose(page)
        pressed = time.time()
        page.keyboard.down("w")
        # The robot publishes its pose through the uplink: the page sees it move.
        page.wait_for_function("([x, y]) => { const el = document.getElementById('pose');"
                               " return Math.hypot(el.dataset.x - x, el.dataset.y - y) > 0.3; }",
                               arg=list(start), timeout=10_000)
        held = [m for m in world.received() if m["t"] > pressed]
        assert held and all(m["msg"]["linear"]["x"] > 0 for m in held), held[-5:]
        released = time.time()
        page.keyboard.up("w")
        wait_until(lambda: any(not _moving(m) for m in world.received() if m["t"] > released), timeout=3,
                   what="a zero Twist at the robot after the key's release")
        expect(page.locator("#cmd-vel")).to_have_attribute("data-linear", "0")
        expect(page.locator("#odom-vel")).to_have_attribute("data-linear", "0", timeout=5_000)
        assert not _moving(world.received()[-1]), "the robot was left moving"
        page.click("#lock-release")
        expect(page.locator("#lock-state")).to_have_text("Nobody is driving")
        assert errors == []
    finally:
        context.close()


async def _drive(world: World, seconds: float, during: Callable[[], None] | None = None) -> None:
    """A driver's page holding a key (input every 50 ms throughout); ``during`` runs once the robot moves."""
    client = world.client("otto")
    before = len(await asyncio.to_thread(world.received))
    # (close_timeout: with the robot away, the server takes its time answering a page's close)
    async with connect(f"ws://127.0.0.1:{world.stack.web_port}/ws/teleop/", origin=Origin(world.stack.url),
                       additional_headers={"Cookie": client.cookie}, close_timeout=1) as ws:
        end = time.monotonic() + seconds

        async def hold() -> None:
            while time.monotonic() < end:
                await ws.send(json.dumps(FORWARD))
                await asyncio.sleep(0.05)

        holding = asyncio.ensure_future(hold())
        while not any(_moving(m) for m in (await asyncio.to_thread(world.received))[before:]):
            assert time.monotonic() < end, "the robot never moved"
        if during is not None:
            await asyncio.to_thread(during)
        await holding


def _moving(m: dict) -> bool:
    return m["msg"]["linear"]["x"] != 0 or m["msg"]["angular"]["z"] != 0


def test_driving_reaches_the_robot_and_a_dropped_uplink_stops_it_from_the_agent(world: World) -> None:
    dropped: list[float] = []

    def drop() -> None:
        logged = len(world.agent.log())
        world.front.kill()  # the uplink drops mid-drive
        dropped.append(time.time())
        world.agent.wait_log("stopping the robot: the uplink dropped", after=logged)

    run_coroutine(_drive(world, 1.0, during=drop))
    after = [m for m in world.received() if m["t"] > dropped[0]]
    assert after and not _moving(after[-1]), "the robot was left moving"
    world.front.start()
    world.wait_online()
    run_coroutine(_drive(world, 0.5))  # driving works again, nobody restarted anything by hand


def test_the_estop_stops_the_robot_through_the_uplink_and_its_release_lets_it_drive(world: World) -> None:
    operator = world.client("otto")
    before = len(world.received())
    status, body = operator.post("/api/robot/estop/", {})
    assert status == 200, body
    wait_until(lambda: any(not _moving(m) for m in world.received()[before:]), timeout=3, what="the stop's zero")
    assert operator.post("/api/robot/motors/", {"enabled": True})[0] != 200  # latched: motion is refused
    status, body = operator.post("/api/robot/estop/release/", {"confirm": True})
    assert status == 200, body
    assert operator.post("/api/robot/motors/", {"enabled": True})[0] == 200
    run_coroutine(_drive(world, 0.5))


def test_the_agent_and_the_server_restarting_are_survived(world: World) -> None:
    world.agent.stop(9)
    wait_until(lambda: not world.uplinked(), timeout=10, what="the server noticing the agent gone")
    assert "no uplink from the robot" in world.health()["reached"]
    world.agent.start()
    world.wait_online()
    web = world.stack.web if not world.stack.scaled else world.stack.link_proc
    web.terminate()
    web.wait(15)
    if world.stack.scaled:
        world.stack.start_link()
    else:
        world.stack.start_web()
    world.wait_online(timeout=30)
    before = len(world.received("/cyborg_audio/text_to_speech"))
    assert world.client("otto").post("/api/robot/speech/", {"text": "back"})[0] == 200
    wait_until(lambda: len(world.received("/cyborg_audio/text_to_speech")) > before, timeout=5, what="a command")


def test_a_map_goal_reaches_the_robot_and_its_status_comes_back(world: World) -> None:
    status, goal = world.client("otto").post("/api/navigation/goal/", {"x": 1.0, "y": -2.0, "yaw": 0.0})
    assert status == 200, goal
    wait_until(lambda: any(m["msg"]["goal_id"]["id"] == goal["id"] for m in world.received("/move_base/goal")),
               timeout=5, what="the goal at the robot")
    wait_until(lambda: world.client("otto").get("/api/navigation/status/")[1]["goal"]["status"] in ("active",
               "succeeded"), timeout=10, interval=0.1, what="the robot's goal status, told through the uplink")
    assert world.client("otto").post("/api/navigation/cancel/", {})[0] == 200


async def _listen_and_talk(world: World) -> int:
    """The robot's microphone heard and the operator's voice sent, over one audio socket; the chunks heard."""
    heard = 0
    async with connect(f"ws://127.0.0.1:{world.stack.web_port}/ws/audio/", origin=Origin(world.stack.url),
                       additional_headers={"Cookie": world.client("otto").cookie}, close_timeout=1) as ws:
        await ws.send(json.dumps({"type": "listen", "on": True}))
        while heard < 10:
            frame = await asyncio.wait_for(ws.recv(), 10)
            heard += isinstance(frame, bytes) and len(frame) == 640
        await ws.send(json.dumps({"type": "listen", "on": False}))
        await ws.send(json.dumps({"type": "talk", "on": True, "format": "S16LE", "rate": 16000, "channels": 1}))
        while True:
            frame = await asyncio.wait_for(ws.recv(), 10)
            if isinstance(frame, str) and json.loads(frame).get("type") == "talking":
                break
        for _ in range(20):
            await ws.send(b"\x00\x10" * 320)  # 20 ms of a quiet hum
            await asyncio.sleep(0.02)
        await ws.send(json.dumps({"type": "talk", "on": False}))
    return heard


def test_listen_and_talk_go_through_the_uplink(world: World) -> None:
    before = len(world.received("/cyborg_audio/speaker"))
    assert run_coroutine(_listen_and_talk(world)) >= 10
    wait_until(lambda: len(world.received("/cyborg_audio/speaker")) >= before + 20, timeout=5,
               what="the operator's voice at the robot's speaker")


def _open(world: World, path: str) -> urllib.request.Request:
    return urllib.request.Request(f"{world.stack.url}{path}", headers={"Cookie": world.client("vera").cookie})


def test_the_camera_comes_through_the_uplink_one_upstream_for_several_viewers(world: World) -> None:
    with urllib.request.urlopen(_open(world, "/video/snapshot"), timeout=10) as res:
        assert res.headers["Content-Type"] == "image/jpeg"
        assert res.read()[:2] == b"\xff\xd8"
    def streams() -> int:
        return json.loads(world.side.fetch(f"http://127.0.0.1:{world.video_port}/sim/introspect"))["video_streams"]

    viewers = [urllib.request.urlopen(_open(world, "/video/stream"), timeout=10) for _ in range(3)]
    try:
        for viewer in viewers:
            assert viewer.headers["Content-Type"].startswith("multipart/x-mixed-replace")
            seen = b""
            while seen.count(b"--boundarydonotcross") < 2:
                seen += viewer.read1(65536)
            assert b"Content-Type: image/jpeg" in seen and b"\xff\xd8" in seen
        assert streams() == 1  # the robot encodes one stream, however many watch
    finally:
        for viewer in viewers:
            viewer.close()


def test_a_stalled_uplink_mid_drive_gets_the_robot_a_zero_twist_from_the_agent(world: World) -> None:
    stalled: list[float] = []

    def stall() -> None:
        logged = len(world.agent.log())
        subprocess.run(["ip", "link", "set", world.side.host_if, "down"], check=True, timeout=10)
        stalled.append(time.time())
        try:
            world.agent.wait_log("stopping the robot: no drive command for", after=logged, timeout=5)
        finally:
            subprocess.run(["ip", "link", "set", world.side.host_if, "up"], check=True, timeout=10)

    run_coroutine(_drive(world, 1.0, during=stall))
    after = [m for m in world.received() if m["t"] > stalled[0]]
    assert after and not _moving(after[0]), "a moving Twist reached the robot after the stall"
    world.wait_online(timeout=30)
    run_coroutine(_drive(world, 0.5))


def test_a_revoked_credential_closes_the_live_uplink_within_a_second_and_is_refused(world: World) -> None:
    key_id = world.agent.env["UPLINK_CREDENTIAL"].split("_")[1]
    logged = len(world.agent.log())
    world.credential(revoke=key_id)
    world.agent.wait_log("uplink lost", after=logged, timeout=5)
    world.agent.wait_log("the server refused the uplink", after=logged, timeout=10)
    code = ("from robot.models import AuditEntry, UplinkCredential\n"
            f"revoked = UplinkCredential.objects.get(key_id={key_id!r}).revoked\n"
            "gone = AuditEntry.objects.filter(action='uplink.disconnect', created__gte=revoked).earliest('created')\n"
            "refused = AuditEntry.objects.filter(action='uplink.refuse', created__gte=revoked).count()\n"
            "print((gone.created - revoked).total_seconds(), gone.outcome, refused)\n")
    line = world.stack.manage("shell", "-c", code).strip().splitlines()[-1]
    seconds, rest = line.split(" ", 1)
    assert float(seconds) < 1.0, line
    assert "revoked" in rest and int(rest.rsplit(" ", 1)[1]) >= 1, line
    assert not world.uplinked()
