"""Store a value as the latest state of its key, then tell every page watching that key.

The one place that does "store it, then tell the watching pages": the link for every robot message
and its connection status, the server for the values it writes itself (the requested mode,
the map's metadata, goals), and a send without storing for values that are never kept.
"""

from __future__ import annotations

import time
from typing import Any

from robot.live import feed
from robot.live.groups import STATUS_KEY, TopicUpdate
from robot.live.state import StateStore, get_store


def server_update(key: str, msg: dict[str, Any], t: float | None = None) -> TopicUpdate:
    """A live update of a key the server writes itself (no ROS topic behind it)."""
    return {"type": "robot.update", "key": key, "topic": "", "msg_type": "", "msg": msg, "t": t or time.time()}


async def aannounce(
    key: str, event: dict[str, Any], *, keep: bool = True, recent: int = 0, store: StateStore | None = None,
) -> None:
    """Store ``event`` as the latest value of ``key`` (and in its recent ring when ``recent``),
    then send it to every page watching ``key``. ``keep=False`` only sends."""
    if keep:
        store = get_store() if store is None else store
        await store.aput(key, dict(event))
        if recent:
            await store.aappend_recent(key, dict(event), recent)
    await feed.announce(event)


async def aannounce_status(status: dict[str, Any], *, store: StateStore | None = None) -> None:
    """Store the link's status and send it to every live page."""
    await (get_store() if store is None else store).aput(STATUS_KEY, dict(status))
    await feed.announce_status(status)


async def apublish_state(key: str, msg: dict[str, Any], t: float | None = None, *, keep: bool = True) -> None:
    """Store ``msg`` as the latest value of a server-written ``key`` and send it to every page watching it."""
    await aannounce(key, dict(server_update(key, msg, t)), keep=keep)


async def aget_state(*keys: str) -> dict[str, dict[str, Any]]:
    """The latest message of each key that has one."""
    entries = await get_store().aget_many(list(keys))
    return {k: e["msg"] for k, e in entries.items()}
