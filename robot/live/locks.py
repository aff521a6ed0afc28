"""Every lock across the web processes and the link, in two kinds, each a redis-py ``Lock``:

- a held lock (the drive lock, the talk lock): a person holds it through one connection, refreshes
  it while they act, and it expires after its time-to-live, so a holder who walks away or a
  process that dies frees it; an admin may take it and the E-STOP clears it. The holder is the
  lock's token, so any process can tell who holds it.
- an exclusive section (a mode change): one at a time, or ``Taken`` at once, expiring after the
  longest the work can take should its process die inside.
"""

from __future__ import annotations

import contextlib
import json
import uuid
from collections.abc import AsyncIterator
from dataclasses import asdict, dataclass
from typing import Any

from django.conf import settings
from redis.exceptions import LockError

from robot.live import redis_clients
from robot.live.state import redis_key


@dataclass(frozen=True)
class Holder:
    owner: str  # the connection that holds it (a channel name)
    username: str

    def encode(self) -> str:
        return json.dumps(asdict(self), sort_keys=True, separators=(",", ":"))

    @classmethod
    def decode(cls, raw: bytes | str | None) -> Holder | None:
        if raw is None:
            return None
        data = json.loads(raw)
        return cls(owner=str(data["owner"]), username=str(data["username"]))


class HeldLock:
    """A held lock on redis-py's ``Lock``, the holder as its token; taking and clearing it whoever
    holds it are plain commands (no lock owns that)."""

    def __init__(self, key: str, ttl_s: float, url: str | None = None) -> None:
        self.url, self.key, self.ttl_s = url or settings.REDIS_URL, key, ttl_s

    def _client(self) -> Any:
        return redis_clients.aclient(self.url)

    def _lock(self, me: Holder) -> Any:
        lock = self._client().lock(self.key, timeout=self.ttl_s, blocking=False, thread_local=False)
        lock.local.token = me.encode().encode()
        return lock

    async def holder(self) -> Holder | None:
        return Holder.decode(await self._client().get(self.key))

    async def acquire(self, me: Holder) -> Holder:
        """Take the lock if it is free (or already mine); return whoever holds it now."""
        for _ in range(3):  # the holder may let go between our two calls
            if await self._lock(me).acquire(token=me.encode()) or await self.refresh(me):
                return me
            current = await self.holder()
            if current is not None:
                return current
        return await self.holder() or me

    async def refresh(self, me: Holder) -> bool:
        """Extend my hold; False if I no longer hold the lock."""
        try:
            await self._lock(me).reacquire()
        except LockError:
            return False
        return True

    async def release(self, me: Holder) -> bool:
        """Free the lock if I hold it."""
        try:
            await self._lock(me).release()
        except LockError:
            return False
        return True

    async def take(self, me: Holder) -> Holder | None:
        """Take the lock whoever holds it (admin takeover); return the previous holder."""
        return Holder.decode(await self._client().set(self.key, me.encode(), px=int(self.ttl_s * 1000), get=True))

    async def clear(self) -> Holder | None:
        """Free the lock whoever holds it (e-stop); return the previous holder."""
        return Holder.decode(await self._client().getdel(self.key))


def held_lock(name: str, ttl_s: float) -> HeldLock:
    """The held lock ``name``."""
    return HeldLock(redis_key(name), ttl_s)


class Taken(Exception):
    """Someone is inside the exclusive section; ``label`` says what they do there."""

    def __init__(self, label: str) -> None:
        super().__init__(label)
        self.label = label


async def is_taken(name: str) -> bool:
    return bool(await redis_clients.aclient().exists(redis_key(name)))


@contextlib.asynccontextmanager
async def exclusive(name: str, label: str, *, ttl_s: float) -> AsyncIterator[None]:
    """Be the one inside section ``name`` for the duration, or raise ``Taken`` at once."""
    lock = redis_clients.aclient().lock(redis_key(name), timeout=ttl_s, blocking=False)
    if not await lock.acquire(token=f"{uuid.uuid4().hex}:{label}"):
        held = await lock.redis.get(redis_key(name))
        raise Taken((held.decode() if isinstance(held, bytes) else held or "").partition(":")[2])
    try:
        yield
    finally:
        with contextlib.suppress(LockError):  # expired meanwhile: nothing of ours to release
            await lock.release()
