"""A restored link never restarts motion by itself: a driver who held a key through a lost connection
(the robot restarting, a blip) moves the robot again only after letting go and pressing again."""

from __future__ import annotations

import asyncio

import pytest

from robot import interface as ri
from tests.helpers import async_wait_until
from tests.teleop.support import drive_socket, is_moving, key, wait_twist

pytestmark = pytest.mark.django_db(transaction=True)


async def test_a_key_held_through_a_lost_link_moves_nothing_until_released_and_pressed_again(link, sim, operator):
    from simulator.harness import SimThread

    ws = await drive_socket(operator)
    frames: list[dict] = []
    held = {"linear": 0.3}

    async def hold() -> None:  # the page repeats the held key every 50 ms, and reads what comes back
        while True:
            await ws.send_json_to(key(held["linear"]))
            while not await ws.receive_nothing(timeout=0.05):
                frames.append(await ws.receive_json_from())

    holding = asyncio.ensure_future(hold())
    revived = None
    try:
        await wait_twist(sim, is_moving, what="the robot driving")
        port = sim.port
        await asyncio.get_running_loop().run_in_executor(None, sim.stop)  # the robot goes, the key stays down
        await async_wait_until(lambda: not link.connected, timeout=15, what="the link noticing")
        revived = SimThread(port=port, video_port=0, startup_s=0.5)
        await asyncio.get_running_loop().run_in_executor(None, revived.start)
        await async_wait_until(lambda: link.connected, timeout=20, what="the link back")
        seen = len(frames)
        await async_wait_until(lambda: any(f.get("code") == "release_first" for f in frames[seen:]), timeout=10,
                               what="the page told to let go first")
        await asyncio.sleep(1.0)  # the key is still held: nothing moves
        assert not any(is_moving(t) for t in revived.received(ri.topic("cmd_vel").name))
        refusal = next(f for f in frames if f.get("code") == "release_first")
        assert "let go" in refusal["message"]

        held["linear"] = 0.0  # the driver lets go …
        await asyncio.sleep(0.3)
        held["linear"] = 0.3  # … and presses again
        await wait_twist(revived, is_moving, timeout=10, what="the robot driving after a fresh press")
    finally:
        holding.cancel()
        await asyncio.gather(holding, return_exceptions=True)
        await ws.disconnect()
        if revived is not None:
            await asyncio.get_running_loop().run_in_executor(None, revived.stop)
