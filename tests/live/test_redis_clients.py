"""The product's Redis clients (robot.live.redis_clients) against a private redis-server that is
really restarted and frozen: the first command after a restart works, on the pooled connection
that went stale, and a frozen Redis ends a command with a timeout instead of holding it."""

from __future__ import annotations

import asyncio
import os
import signal

import pytest
import redis

from robot.live import redis_clients
from tests.support_processes import PrivateRedis


@pytest.fixture
def server():
    running = PrivateRedis().start()
    yield running
    if running.proc is not None and running.proc.poll() is None:
        os.kill(running.proc.pid, signal.SIGCONT)
    running.stop()


async def test_the_first_command_after_a_restart_works_on_both_kinds_of_client(server):
    shared, threads = redis_clients.aclient(server.url), redis_clients.client(server.url)
    assert redis_clients.aclient(server.url) is shared  # one per loop and URL
    await shared.set("k", "before")
    assert threads.get("k") == b"before"
    server.stop()
    server.start()  # the same port, empty: every pooled connection points at the dead server
    await shared.set("k", "after")
    assert await shared.get("k") == b"after"
    assert threads.get("k") == b"after"


async def test_a_frozen_redis_ends_a_command_with_a_timeout_not_a_hang(server):
    shared = redis_clients.aclient(server.url)
    await shared.set("k", "v")
    os.kill(server.proc.pid, signal.SIGSTOP)
    try:
        # redis-py's own defaults (5 s, three retries with backoff) held a command for about 20 s.
        async with asyncio.timeout(redis_clients.COMMAND_TIMEOUT_S * 3):
            with pytest.raises(redis.TimeoutError):
                await shared.get("k")
    finally:
        os.kill(server.proc.pid, signal.SIGCONT)
    assert await shared.get("k") == b"v"  # and it works again once Redis does
