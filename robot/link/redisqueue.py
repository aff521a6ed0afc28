"""The command path when scaled: requests to the link and its replies as Redis lists.

Web processes push requests onto one list the link pops; each process pops its replies
from a list of its own. Plain RPUSH/BLPOP on a client that reconnects by itself: after a
Redis outage the next pop works, where the channel layer's blocking receive could hang or
lose a message (a stalled teleop, an E-STOP that timed out). Every pop waits at most a
second, so a loop around it notices a stop or a dead connection quickly.
"""

from __future__ import annotations

import asyncio
import json
import weakref
from typing import Any

from django.conf import settings

from robot.live.state import redis_key

POP_TIMEOUT_S = 1
KEEP_S = 60  # an abandoned list (its reader died) goes away by itself

_clients: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, Any] = weakref.WeakKeyDictionary()


def requests_key() -> str:
    return redis_key("link-requests")


def _client() -> Any:
    import redis.asyncio

    loop = asyncio.get_running_loop()
    client = _clients.get(loop)
    if client is None:
        client = _clients[loop] = redis.asyncio.Redis.from_url(settings.REDIS_URL)
    return client


async def push(key: str, payload: dict[str, Any]) -> None:
    from redis.exceptions import ConnectionError as RedisConnectionError

    data = json.dumps(payload, default=str)
    for attempt in (1, 2):
        try:
            async with _client().pipeline(transaction=False) as pipe:
                await pipe.rpush(key, data).expire(key, KEEP_S).execute()
            return
        except RedisConnectionError:
            # After an outage the pool may hand out a connection to the old server once;
            # it is dropped on failure, and the second try gets a fresh one.
            if attempt == 2:
                raise


async def pop(key: str) -> dict[str, Any] | None:
    """The next payload on ``key``, or None after a quiet second."""
    popped = await _client().blpop([key], timeout=POP_TIMEOUT_S)
    return None if popped is None else json.loads(popped[1])
