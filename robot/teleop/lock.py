"""The drive lock: one driver at a time, across every web process.

The holder is one websocket connection (its channel name), shown by username. The lock
expires ``TELEOP_LOCK_TTL_S`` after its last refresh (every published Twist refreshes it),
so a driver who walks away, or a web process that dies, frees it. In the embedded default
it lives in this process; with ``REDIS_URL`` it is a Redis key set with ``SET NX PX``.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass
from typing import Any, Protocol

from django.conf import settings

from robot.live import redis_clients
from robot.live.state import redis_key


@dataclass(frozen=True)
class Holder:
    owner: str  # the connection that drives (a channel name)
    username: str

    def encode(self) -> str:
        return json.dumps(asdict(self), sort_keys=True, separators=(",", ":"))

    @classmethod
    def decode(cls, raw: bytes | str | None) -> Holder | None:
        if raw is None:
            return None
        data = json.loads(raw)
        return cls(owner=str(data["owner"]), username=str(data["username"]))


class DriveLock(Protocol):
    async def holder(self) -> Holder | None: ...
    async def acquire(self, me: Holder) -> Holder:
        """Take the lock if it is free (or already mine); return whoever holds it now."""
    async def refresh(self, me: Holder) -> bool:
        """Extend my hold; False if I no longer hold the lock."""
    async def release(self, me: Holder) -> bool:
        """Free the lock if I hold it."""
    async def take(self, me: Holder) -> Holder | None:
        """Take the lock whoever holds it (admin takeover); return the previous holder."""
    async def clear(self) -> Holder | None:
        """Free the lock whoever holds it (e-stop); return the previous holder."""


class MemoryLock:
    def __init__(self, ttl_s: float) -> None:
        self.ttl_s = ttl_s
        self._holder: Holder | None = None
        self._expires = 0.0

    def _current(self) -> Holder | None:
        if self._holder is not None and time.monotonic() >= self._expires:
            self._holder = None
        return self._holder

    def _set(self, me: Holder) -> None:
        self._holder, self._expires = me, time.monotonic() + self.ttl_s

    async def holder(self) -> Holder | None:
        return self._current()

    async def acquire(self, me: Holder) -> Holder:
        current = self._current()
        if current is None or current == me:
            self._set(me)
            return me
        return current

    async def refresh(self, me: Holder) -> bool:
        if self._current() != me:
            return False
        self._set(me)
        return True

    async def release(self, me: Holder) -> bool:
        if self._current() != me:
            return False
        self._holder = None
        return True

    async def take(self, me: Holder) -> Holder | None:
        previous = self._current()
        self._set(me)
        return previous

    async def clear(self) -> Holder | None:
        previous, self._holder = self._current(), None
        return previous


# Compare-and-act scripts: only the holder may extend or free its own lock.
_REFRESH = "if redis.call('GET', KEYS[1]) == ARGV[1] then return redis.call('PEXPIRE', KEYS[1], ARGV[2]) end return 0"
_RELEASE = "if redis.call('GET', KEYS[1]) == ARGV[1] then return redis.call('DEL', KEYS[1]) end return 0"


class RedisLock:
    def __init__(self, url: str, key: str, ttl_s: float) -> None:
        self.url, self.key, self.ttl_ms = url, key, int(ttl_s * 1000)

    def _client(self) -> Any:
        return redis_clients.aclient(self.url)

    async def holder(self) -> Holder | None:
        return Holder.decode(await self._client().get(self.key))

    async def acquire(self, me: Holder) -> Holder:
        client = self._client()
        for _ in range(3):  # the holder may let go between our two calls
            if await client.set(self.key, me.encode(), nx=True, px=self.ttl_ms):
                return me
            if await self.refresh(me):
                return me
            current = await self.holder()
            if current is not None:
                return current
        return await self.holder() or me

    async def refresh(self, me: Holder) -> bool:
        return bool(await self._client().eval(_REFRESH, 1, self.key, me.encode(), self.ttl_ms))

    async def release(self, me: Holder) -> bool:
        return bool(await self._client().eval(_RELEASE, 1, self.key, me.encode()))

    async def take(self, me: Holder) -> Holder | None:
        return Holder.decode(await self._client().set(self.key, me.encode(), px=self.ttl_ms, get=True))

    async def clear(self) -> Holder | None:
        return Holder.decode(await self._client().getdel(self.key))


_lock: DriveLock | None = None


def get_lock() -> DriveLock:
    global _lock
    if _lock is None:
        if settings.REDIS_URL:
            _lock = RedisLock(settings.REDIS_URL, redis_key("teleop-lock"), settings.TELEOP_LOCK_TTL_S)
        else:
            _lock = MemoryLock(settings.TELEOP_LOCK_TTL_S)
    return _lock


def reset_lock() -> None:
    """Forget the configured lock (tests that change settings)."""
    global _lock
    _lock = None
