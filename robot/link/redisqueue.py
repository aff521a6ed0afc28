"""The command path when scaled: requests to the link and its replies as Redis lists.

Web processes push requests onto one list the link pops; each process pops its replies
from a list of its own. Plain RPUSH/BLPOP on a client that reconnects by itself: after a
Redis outage the next pop works, where the channel layer's blocking receive could hang or
lose a message (a stalled teleop, an E-STOP that timed out). Every pop waits at most a
second, so a loop around it notices a stop or a dead connection quickly.
"""

from __future__ import annotations

import json
from typing import Any

from robot.live import redis_clients
from robot.live.state import redis_key

POP_TIMEOUT_S = 1
KEEP_S = 60  # an abandoned list (its reader died) goes away by itself



def requests_key() -> str:
    return redis_key("link-requests")


async def push(key: str, payload: dict[str, Any]) -> None:
    # (After an outage the pool may hand out a connection to the old server once: the client
    # drops it and tries again on a fresh one, robot.live.redis_clients.)
    async with redis_clients.aclient().pipeline(transaction=False) as pipe:
        await pipe.rpush(key, json.dumps(payload, default=str)).expire(key, KEEP_S).execute()


async def pop(key: str) -> dict[str, Any] | None:
    """The next payload on ``key``, or None after a quiet second."""
    popped = await redis_clients.aclient(blocking_s=POP_TIMEOUT_S).blpop([key], timeout=POP_TIMEOUT_S)
    return None if popped is None else json.loads(popped[1])
