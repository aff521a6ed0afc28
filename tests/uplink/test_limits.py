"""The uplink endpoint's limits and its one-uplink-per-robot rule, with a raw websocket client as the agent."""

from __future__ import annotations

import asyncio

import pytest
from asgiref.sync import sync_to_async
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed

from robot.models import AuditEntry
from tests.helpers import async_wait_until
from tests.stack import free_port
from uplink_agent import mux

pytestmark = pytest.mark.django_db(transaction=True)


@pytest.fixture
async def strict(settings, transactional_db):
    """An endpoint that takes frames up to 4 KB and 20 messages a second."""
    from robot.uplink import hosting

    settings.UPLINK_LISTEN = f"127.0.0.1:{free_port()}"
    settings.UPLINK_ROSBRIDGE_PORT, settings.UPLINK_VIDEO_PORT = free_port(), free_port()
    settings.UPLINK_MAX_FRAME_BYTES, settings.UPLINK_MAX_MESSAGES_PER_S = 4096, 20
    made = hosting.make_endpoint()
    await made.start()
    yield made
    await made.stop()


def _agent(endpoint, text: str):
    return connect(f"ws://127.0.0.1:{endpoint.port}/uplink/", additional_headers={"Authorization": f"Bearer {text}"})


async def _outcomes(action: str, *, wait_for: str = "") -> list[str]:
    """The audit's outcomes for ``action``; with ``wait_for``, once one contains it (written after the close)."""

    def read() -> list[str]:
        return list(AuditEntry.objects.filter(action=action).values_list("outcome", flat=True))

    for _ in range(250):
        found = await sync_to_async(read)()
        if not wait_for or any(wait_for in outcome for outcome in found):
            return found
        await asyncio.sleep(0.02)
    raise AssertionError(f"no {action} audit entry saying {wait_for!r}: {found}")


async def test_a_frame_over_the_limit_closes_the_uplink(strict, credential):
    async with _agent(strict, credential[1]) as ws:
        await async_wait_until(lambda: strict.live is not None, timeout=5, what="uplink open")
        await ws.send(mux.encode(mux.DATA, 1, b"x" * 5000))
        with pytest.raises(ConnectionClosed) as closed:
            await ws.recv()
    assert closed.value.rcvd.code == 1009
    await async_wait_until(lambda: strict.live is None, timeout=5, what="uplink gone")


async def test_a_flood_of_messages_closes_the_uplink(strict, credential):
    async with _agent(strict, credential[1]) as ws:
        await async_wait_until(lambda: strict.live is not None, timeout=5, what="uplink open")
        with pytest.raises(ConnectionClosed) as closed:
            for _ in range(200):
                await ws.send(mux.encode(mux.DATA, 1, b"{}"))
            await ws.recv()
    assert closed.value.rcvd.code == 4002
    await async_wait_until(lambda: strict.live is None, timeout=5, what="uplink gone")
    await _outcomes("uplink.disconnect", wait_for="messages a second")


async def test_a_second_uplink_for_the_robot_takes_over_and_says_so(strict, credential):
    async with _agent(strict, credential[1]) as first:
        await async_wait_until(lambda: strict.live is not None, timeout=5, what="first uplink open")
        async with _agent(strict, credential[1]):
            await async_wait_until(lambda: first.close_code is not None and strict.live is not None, timeout=5,
                                   what="the take-over")
            assert first.close_code == 4000 and strict.live is not None
            assert len(await _outcomes("uplink.takeover", wait_for="took over from 127.0.0.1")) == 1
    await _outcomes("uplink.disconnect", wait_for="taken over by 127.0.0.1")
