"""Requests to the robot link and its replies: named queues of JSON payloads, the same calls in
both wirings. In the embedded default they live in this process (the link runs on an event loop
of its own, so a queue wakes a reader on whichever loop waits); with ``REDIS_URL`` they are Redis
lists, RPUSH/BLPOP on a client that reconnects by itself, so after an outage the next pop works.
A pop waits at most ``POP_TIMEOUT_S``: a loop around it notices a stop or a dead connection quickly.
"""

from __future__ import annotations

import asyncio
import json
import threading
from collections import defaultdict, deque
from typing import Any

from django.conf import settings

from robot.live import redis_clients
from robot.live.state import redis_key

POP_TIMEOUT_S = 1
KEEP_S = 60  # an abandoned Redis list (its reader died) goes away by itself


def requests_key() -> str:
    return redis_key("link-requests")


async def push(key: str, payload: dict[str, Any]) -> None:
    if not settings.REDIS_URL:
        _memory.push(key, payload)
        return
    # (After an outage the pool may hand out a connection to the old server once: the client
    # drops it and tries again on a fresh one, robot.live.redis_clients.)
    async with redis_clients.aclient().pipeline(transaction=False) as pipe:
        await pipe.rpush(key, json.dumps(payload, default=str)).expire(key, KEEP_S).execute()


async def pop(key: str) -> dict[str, Any] | None:
    """The next payload on ``key``, or None after a quiet ``POP_TIMEOUT_S``."""
    if not settings.REDIS_URL:
        return await _memory.pop(key, POP_TIMEOUT_S)
    popped = await redis_clients.aclient(blocking_s=POP_TIMEOUT_S).blpop([key], timeout=POP_TIMEOUT_S)
    return None if popped is None else json.loads(popped[1])


class _MemoryQueues:
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._items: defaultdict[str, deque[dict[str, Any]]] = defaultdict(deque)
        self._readers: defaultdict[str, list[asyncio.Future[None]]] = defaultdict(list)

    def push(self, key: str, payload: dict[str, Any]) -> None:
        with self._lock:
            self._items[key].append(payload)
            readers = self._readers.pop(key, [])
        for reader in readers:
            reader.get_loop().call_soon_threadsafe(_wake, reader)

    async def pop(self, key: str, timeout: float) -> dict[str, Any] | None:
        try:
            async with asyncio.timeout(timeout):
                while True:
                    with self._lock:
                        items = self._items.get(key)
                        if items:
                            payload = items.popleft()
                            if not items:
                                del self._items[key]
                            return payload
                        woken = asyncio.get_running_loop().create_future()
                        self._readers[key].append(woken)
                    try:
                        await woken
                    finally:
                        self._forget(key, woken)
        except TimeoutError:
            return None

    def _forget(self, key: str, reader: asyncio.Future[None]) -> None:
        with self._lock:
            readers = self._readers.get(key)
            if readers and reader in readers:
                readers.remove(reader)
                if not readers:
                    del self._readers[key]


def _wake(reader: asyncio.Future[None]) -> None:
    if not reader.done():
        reader.set_result(None)


_memory = _MemoryQueues()
