"""The Redis channel layer as configured: a receive on a quiet channel outlasts the socket timeout."""

import asyncio

from channels.layers import get_channel_layer


async def test_a_receive_waits_quietly_past_the_blocking_pop_and_still_gets_the_message():
    layer = get_channel_layer()
    receiving = asyncio.ensure_future(layer.receive("quiet-test"))
    await asyncio.sleep(6.5)  # longer than one blocking pop (5 s) and redis-py 8's default read timeout
    assert not receiving.done(), receiving.exception() if receiving.done() else None
    await layer.send("quiet-test", {"type": "ping"})
    assert (await asyncio.wait_for(receiving, 5))["type"] == "ping"
