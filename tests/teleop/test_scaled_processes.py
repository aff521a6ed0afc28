"""The scaled wiring as real processes (private redis-server, simulator, Daphne, robotlink):
driving reaches the robot at the teleop rate through the link, the link stops the robot
itself when a SIGKILLed web process goes quiet, and a SIGTERMed web process or link sends
zero before it exits."""

from __future__ import annotations

import asyncio
import itertools
import json
import os
import signal
import time

import pytest
from django.conf import settings
from websockets.asyncio.client import connect

from tests.helpers import wait_until
from tests.stack import Stack
from tests.support_processes import Client, PrivateRedis, received

pytestmark = [pytest.mark.redis, pytest.mark.skipif(settings.EMBEDDED, reason="scaled wiring: services pass")]
FORWARD = {"type": "input", "linear": 1.0, "angular": 0.0}


def moving(m: dict) -> bool:
    return m["msg"]["linear"]["x"] != 0


@pytest.fixture(scope="module")
def scaled():
    redis = PrivateRedis().start()
    # A dead driver's lock frees quickly, so the next test can drive.
    stack = Stack(redis_url=redis.url, env={"TELEOP_LOCK_TTL_S": "1"})
    stack.redis = redis
    try:
        stack.start()
        stack.wait_robot_online(timeout=40)
        operator = Client(stack, "otto")
        assert operator.post("/api/robot/motors/", {"enabled": True})[0] == 200
        yield stack
    finally:
        stack.stop()
        redis.stop()


async def hold_w(stack: Stack, seconds: float, *, during=None) -> None:
    """A driver's page holding W (input every 50 ms); ``during`` runs once driving started."""
    client = Client(stack, "otto")
    before = len(await asyncio.to_thread(received, stack))
    async with connect(f"ws://127.0.0.1:{stack.web_port}/ws/teleop/", origin=stack.url,
                       additional_headers={"Cookie": client.cookie}) as ws:
        end = time.monotonic() + seconds
        started = False
        try:
            while time.monotonic() < end:
                await ws.send(json.dumps(FORWARD))
                await asyncio.sleep(0.05)
                if not started and any(moving(m) for m in (await asyncio.to_thread(received, stack))[before:]):
                    started = True
                    if during is not None:
                        await asyncio.to_thread(during)
        except Exception:
            if during is None:
                raise  # the web process went away under us: expected only when we killed it


def _wait_link_running(stack: Stack) -> None:
    """Until the link says it runs, its signal handlers in place (the store may still show the previous
    link online, so wait_robot_online can return before it)."""
    wait_until(lambda: "Ctrl-C to stop." in stack.log("link"), timeout=30)


def restart_web(stack: Stack) -> None:
    stack.web.wait(10)
    stack.start_web()
    stack.wait_robot_online(timeout=30)
    time.sleep(1.2)  # the dead driver's lock expires


def test_driving_reaches_the_robot_at_the_teleop_rate(scaled):
    before = len(received(scaled))
    asyncio.run(hold_w(scaled, 2.0))
    twists = [m for m in received(scaled)[before:] if moving(m)]
    assert len(twists) >= 12, f"only {len(twists)} moving Twists in 2 s"
    gaps = [b["t"] - a["t"] for a, b in itertools.pairwise(twists)]
    assert max(gaps) < settings.TELEOP_LINK_DEADMAN_S, gaps  # never a stall the link's deadman would cut


def test_a_sigkilled_web_process_still_stops_the_robot(scaled):
    kill_at: list[float] = []

    def kill() -> None:
        kill_at.append(time.time())
        os.kill(scaled.web.pid, signal.SIGKILL)

    asyncio.run(hold_w(scaled, 1.5, during=kill))
    wait_until(lambda: [m for m in received(scaled) if m["t"] > kill_at[0] and not moving(m)], timeout=5,
               what="the link's own zero Twist")
    assert not moving(received(scaled)[-1])
    assert "went quiet" in scaled.log("link")
    restart_web(scaled)


def test_a_sigtermed_web_process_sends_zero_before_exiting(scaled):
    term_at: list[float] = []
    len_before_quiet = len(scaled.log("link"))

    def term() -> None:
        term_at.append(time.time())
        os.kill(scaled.web.pid, signal.SIGTERM)

    asyncio.run(hold_w(scaled, 1.5, during=term))
    wait_until(lambda: scaled.web.poll() is not None, timeout=10, what="the web process to exit")
    assert "sent zero for 1 driver(s)" in scaled.log("web")
    after = [m for m in received(scaled) if m["t"] > term_at[0]]
    assert after and not moving(after[-1])
    assert "went quiet" not in scaled.log("link")[len_before_quiet:], "the web process left it to the link's deadman"
    restart_web(scaled)


def test_a_sigtermed_link_sends_zero_before_exiting(scaled):
    client = Client(scaled, "otto")
    status, body = client.post("/api/robot/motors/", {"enabled": True})
    assert status == 200, body

    def term_link() -> None:
        os.kill(scaled.link_proc.pid, signal.SIGTERM)
        scaled.link_proc.wait(15)

    before, logged = len(received(scaled)), len(scaled.log("link"))
    asyncio.run(hold_w(scaled, 1.0, during=term_link))
    twists = received(scaled)[before:]
    assert twists and not moving(twists[-1]), "the link exited leaving the robot moving"
    said = scaled.log("link")[logged:]
    assert scaled.link_proc.returncode == 0, said
    assert "robot link stopped: background services in" in said and "Robot link stopped." in said, said
    scaled.start_link()
    scaled.wait_robot_online(timeout=30)


def test_a_link_whose_stop_overruns_its_deadline_exits_with_every_threads_stack_in_its_log(scaled):
    _wait_link_running(scaled)
    scaled.link_proc.terminate()
    assert scaled.link_proc.wait(15) == 0
    scaled.env["ROBOT_LINK_STOP_DEADLINE_S"] = "0.3"
    try:
        scaled.start_link()  # a new log
        _wait_link_running(scaled)
    finally:
        del scaled.env["ROBOT_LINK_STOP_DEADLINE_S"]
    logged = len(scaled.log("link"))
    # Redis frozen: the stop's hand-over waits on it (each wait bounded at a second or more), past the deadline.
    scaled.redis.proc.send_signal(signal.SIGSTOP)
    try:
        os.kill(scaled.link_proc.pid, signal.SIGTERM)
        returncode = scaled.link_proc.wait(15)
    finally:
        scaled.redis.proc.send_signal(signal.SIGCONT)
    said = scaled.log("link")[logged:]
    assert returncode == 1, said
    assert "exiting within 0.3 s" in said, said
    assert "Timeout (0:00:00.300000)!" in said and "(most recent call first)" in said, said  # faulthandler's
    scaled.start_link()
    scaled.wait_robot_online(timeout=30)
