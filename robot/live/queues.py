"""Requests to the robot link and its replies: named queues of JSON payloads, Redis lists (RPUSH/BLPOP)
on a client that reconnects by itself, so after an outage the next pop works. A pop waits at most
``POP_TIMEOUT_S``: a loop around it notices a stop or a dead connection quickly.
"""

from __future__ import annotations

import json
from typing import Any

from robot.live import redis_clients
from robot.live.state import redis_key

POP_TIMEOUT_S = 1
KEEP_S = 60  # an abandoned Redis list (its reader died) goes away by itself


def requests_key() -> str:
    return redis_key("link-requests")


async def push(key: str, payload: dict[str, Any]) -> None:
    # (After an outage the pool may hand out a connection to the old server once: the client
    # drops it and tries again on a fresh one, robot.live.redis_clients.)
    async with redis_clients.aclient().pipeline(transaction=False) as pipe:
        await pipe.rpush(key, json.dumps(payload, default=str)).expire(key, KEEP_S).execute()


async def pop(key: str) -> dict[str, Any] | None:
    """The next payload on ``key``, or None after a quiet ``POP_TIMEOUT_S``."""
    popped = await redis_clients.aclient(blocking_s=POP_TIMEOUT_S).blpop([key], timeout=POP_TIMEOUT_S)
    return None if popped is None else json.loads(popped[1])
