"""A tool publishing velocity through a lost link moves nothing once the link is back until it has
published a stop, as on the Drive page; it hears why in a status frame."""

from __future__ import annotations

import asyncio
import json

import pytest

from robot import interface as ri
from tests.frontdoor.test_access import door
from tests.helpers import async_wait_until
from tests.teleop.support import is_moving, wait_twist

pytestmark = pytest.mark.django_db(transaction=True)
CMD_VEL = ri.topic("cmd_vel").name


async def test_a_tool_publishing_through_a_lost_link_must_send_a_stop_before_it_moves_again(link, sim, operator):
    from simulator.harness import SimThread

    ws, connected = await door(operator)
    assert connected
    frames: list[dict] = []
    speed = {"x": 0.3}

    async def publish() -> None:  # the tool publishes at 20 Hz, and reads what comes back
        while True:
            await ws.send_json_to({"op": "publish", "topic": CMD_VEL,
                                   "msg": {"linear": {"x": speed["x"]}, "angular": {"z": 0.0}}})
            while not await ws.receive_nothing(timeout=0.05):
                frames.append(json.loads(await ws.receive_from()))

    publishing = asyncio.ensure_future(publish())
    revived = None
    try:
        await wait_twist(sim, is_moving, what="the robot driving")
        port = sim.port
        await asyncio.get_running_loop().run_in_executor(None, sim.stop)
        await async_wait_until(lambda: not link.connected, timeout=15, what="the link noticing")
        revived = SimThread(port=port, video_port=0, startup_s=0.5)
        await asyncio.get_running_loop().run_in_executor(None, revived.start)
        await async_wait_until(lambda: link.connected, timeout=20, what="the link back")
        seen = len(frames)
        await async_wait_until(lambda: any(f.get("op") == "status" and "let go" in f.get("msg", "")
                                           for f in frames[seen:]), timeout=10, what="the tool told to stop first")
        await asyncio.sleep(1.0)
        assert not any(is_moving(t) for t in revived.received(CMD_VEL))
        speed["x"] = 0.0  # the tool publishes a stop …
        await asyncio.sleep(0.3)
        speed["x"] = 0.3  # … and moves again
        await wait_twist(revived, is_moving, timeout=10, what="the robot driving after a stop")
    finally:
        publishing.cancel()
        await asyncio.gather(publishing, return_exceptions=True)
        await ws.disconnect()
        if revived is not None:
            await asyncio.get_running_loop().run_in_executor(None, revived.stop)
