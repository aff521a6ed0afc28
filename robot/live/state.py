"""The latest-state store: the newest message of every monitored topic, plus link status.

In Redis (the embedded default's private server or ``REDIS_URL``), so the dashboard, the API, the
recorder and the link of any process read and write the same values.
"""

from __future__ import annotations

import json
import time
from typing import Any

import numpy as np
from django.conf import settings

from robot.live import redis_clients
from robot.live.groups import STATUS_KEY


def jsonable(value: Any) -> Any:
    """``default`` for ``json.dumps``: arrays the link decoded (a large map's data) back to lists."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"Object of type {type(value).__name__} is not JSON serializable")


class StateStore:
    """A Redis hash of the newest entry per key under ``name``, and a capped list per key of the recent ones."""

    def __init__(self, name: str, url: str | None = None) -> None:
        self._name = name
        self._url = url or settings.REDIS_URL
        self._sync = redis_clients.client(self._url)

    def _aclient(self) -> Any:
        return redis_clients.aclient(self._url)

    async def aput(self, key: str, entry: dict[str, Any]) -> None:
        await self._aclient().hset(self._name, key, json.dumps(entry, default=jsonable))

    def put(self, key: str, entry: dict[str, Any]) -> None:
        self._sync.hset(self._name, key, json.dumps(entry, default=jsonable))

    async def aget_many(self, keys: list[str]) -> dict[str, dict[str, Any]]:
        if not keys:
            return {}
        values = await self._aclient().hmget(self._name, keys)
        return {k: json.loads(v) for k, v in zip(keys, values, strict=True) if v is not None}

    def get_all(self) -> dict[str, dict[str, Any]]:
        items = self._sync.hgetall(self._name).items()
        return {k.decode() if isinstance(k, bytes) else k: json.loads(v) for k, v in items}

    async def aappend_recent(self, key: str, entry: dict[str, Any], maxlen: int) -> None:
        name = f"{self._name}:recent:{key}"
        async with self._aclient().pipeline(transaction=False) as pipe:
            await pipe.rpush(name, json.dumps(entry, default=jsonable)).ltrim(name, -maxlen, -1).execute()

    async def aget_recent(self, key: str) -> list[dict[str, Any]]:
        return [json.loads(v) for v in await self._aclient().lrange(f"{self._name}:recent:{key}", 0, -1)]

    def get_recent(self, key: str) -> list[dict[str, Any]]:
        return [json.loads(v) for v in self._sync.lrange(f"{self._name}:recent:{key}", 0, -1)]

    def clear(self) -> None:
        self._sync.delete(self._name, *self._sync.keys(f"{self._name}:recent:*"))


def redis_key(name: str) -> str:
    """A Redis key under this deployment's prefix (the channel layer's, so tests can isolate both)."""
    config = settings.CHANNEL_LAYERS["default"].get("CONFIG", {})
    return f"{config.get('prefix', 'cyborg')}:{name}"


_store: StateStore | None = None


def get_store() -> StateStore:
    global _store
    if _store is None:
        _store = StateStore(redis_key("latest-state"))
    return _store


def reset_store() -> None:
    global _store
    _store = None


def link_status(store: StateStore | None = None) -> dict[str, Any]:
    """The link's last reported status; offline when the link has not reported recently."""
    return status_view((store or get_store()).get_all().get(STATUS_KEY))


def status_view(status: dict[str, Any] | None, now: float | None = None) -> dict[str, Any]:
    now = now or time.time()
    if not status:
        return {"connected": False, "robot_connected": False, "command_path": False, "responding": True,
                "url": settings.ROSBRIDGE_URL,
                "since": None, "attempts": 0, "link_alive": None}
    alive = now - float(status.get("link_alive") or 0) < LINK_HEARTBEAT_S * 3
    robot = bool(status.get("connected")) and alive
    path = alive and bool(status.get("command_path", True))
    responding = not robot or bool(status.get("responding", True))
    # "connected" only when a command can reach the robot: the robot is there, answers, and the link answers.
    return {**status, "connected": robot and path and responding, "robot_connected": robot,
            "command_path": path, "responding": responding,
            # A link just started (taking over) queues commands for its first connection.
            "connecting": alive and not robot and now < float(status.get("connecting_until") or 0),
            "link_running": alive}


LINK_HEARTBEAT_S = 2.0
