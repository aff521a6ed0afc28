"""The robot link's lease: of several link processes only the holder connects to the robot and publishes.

A standard Redis lock (redis-py's ``Lock``: SET NX with a time to live), renewed by the holder
well inside that time, its token compared with the one in Redis before every publish (the
fencing check). A holder that cannot renew before the lease runs out, or finds another token,
has lost it and stops at once; a holder that dies stops renewing, and a standby takes the key
when it expires. The token names the holder, so anyone can see which process is active.

While Redis cannot be reached at all, nobody can take the lease, so the holder keeps its robot
connection but only to stop the robot (``may_stop``): the E-STOP does not depend on Redis. It
takes its key back when Redis returns, or stops if another link was quicker.
"""

from __future__ import annotations

import asyncio
import logging
import time
import uuid

from redis.asyncio.lock import Lock
from redis.exceptions import LockError, LockNotOwnedError, RedisError

from robot.live import redis_clients

log = logging.getLogger(__name__)


class Lease:
    def __init__(self, url: str, key: str, *, holder: str, ttl_s: float = 2.0, poll_s: float = 0.2) -> None:
        self.holder = holder
        self.ttl_s = ttl_s
        self.renew_s = ttl_s / 4
        self.poll_s = poll_s
        self.token = f"{holder}:{uuid.uuid4().hex}".encode()
        # Every Redis call must come back well inside the lease, or the holder cannot know it still holds it.
        self.client = redis_clients.new_aclient(url, socket_timeout=ttl_s / 4, socket_connect_timeout=ttl_s / 4)
        self.lock = Lock(self.client, key, timeout=ttl_s, thread_local=False)
        self.lost = asyncio.Event()
        self.acquired_at: float | None = None
        self._valid_until = 0.0  # monotonic: the lease is ours at most until then
        self._redis_down = False

    @property
    def held(self) -> bool:
        return time.monotonic() < self._valid_until and not self.lost.is_set()

    @property
    def may_stop(self) -> bool:
        """Held, or held until Redis went out of reach: the robot may be stopped from here."""
        return self.held or (self._redis_down and self.acquired_at is not None and not self.lost.is_set())

    async def acquire(self) -> None:
        """Wait (as the standby) until this process holds the lease."""
        while True:
            if self._redis_down:
                # Redis is back, maybe empty after a restart: leave the holder a lease's time to take its
                # key back, so a Redis restart does not move the robot to the other link.
                await asyncio.sleep(self.ttl_s)
            started = time.monotonic()
            try:
                if await self._redis_just_started():
                    # The same wait, when the client reconnected by itself and never saw the outage.
                    await asyncio.sleep(self.ttl_s)
                    continue
                acquired = await self.lock.acquire(blocking=False, token=self.token)
                self._redis_ok()
                if acquired:
                    self._held_from(started)
                    self.acquired_at = time.time()
                    log.info("robot link %s holds the lease", self.holder)
                    return
            except RedisError:
                self._redis_failed()
            await asyncio.sleep(self.poll_s)

    async def hold(self) -> None:
        """Renew the lease until it is lost; returns then (``lost`` is set)."""
        while not self.lost.is_set():
            await asyncio.sleep(self.renew_s)
            started = time.monotonic()
            try:
                await self.lock.reacquire()
                self._held_from(started)
                self._redis_ok()
            except LockNotOwnedError:
                # Gone (expired, or Redis restarted empty) or taken. Take it back only if nobody has it.
                if not await self._retake(started):
                    self._lose("another link holds it")
            except RedisError:
                self._redis_failed()
                if time.monotonic() >= self._valid_until:
                    await self._await_redis()

    async def _await_redis(self) -> None:
        """Past the lease with Redis out of reach: stop-only until Redis answers, then take the key
        back (the standby waits a lease's time after an outage before it tries) or give up."""
        log.error("robot link %s cannot renew its lease while Redis is unreachable: it only stops the robot "
                  "until Redis returns", self.holder)
        while True:
            await asyncio.sleep(self.poll_s)
            started = time.monotonic()
            try:
                if await self.lock.owned() or await self.lock.do_acquire(self.token):
                    self._held_from(started)
                    self._redis_ok()
                    log.warning("robot link %s holds its lease again", self.holder)
                    return
            except RedisError:
                continue
            self._redis_ok()
            self._lose("another link took it while Redis was unreachable")
            return

    async def check(self) -> bool:
        """Before every publish: the lease is still ours, by the token stored in Redis."""
        if not self.held:
            return False
        started = time.monotonic()
        try:
            if await self.lock.owned():
                return True
        except RedisError:
            return False  # cannot prove it: do not publish
        if await self._retake(started):
            return True
        self._lose("another link holds it")
        return False

    async def release(self) -> None:
        """Hand over at once (a clean stop): the standby need not wait for the lease to expire."""
        self.lost.set()
        self._valid_until = 0.0
        try:
            await self.lock.release()
            log.info("robot link %s released its lease", self.holder)
        except (LockError, RedisError):
            pass  # expired or taken meanwhile: nothing to hand over

    async def close(self) -> None:
        await self.client.aclose()

    async def _retake(self, started: float) -> bool:
        try:
            if await self.lock.do_acquire(self.token):
                self._held_from(started)
                log.warning("robot link %s took its lease back (the key had gone, e.g. Redis restarted)", self.holder)
                return True
        except RedisError:
            pass
        return False

    async def _redis_just_started(self) -> bool:
        """Redis (re)started less than a lease's time ago: it may have lost a live holder's key."""
        info = await self.client.info("server")
        return float(info.get("uptime_in_seconds", self.ttl_s)) < self.ttl_s

    def _held_from(self, started: float) -> None:
        self._valid_until = started + self.ttl_s
        self.lost.clear()

    def _lose(self, why: str) -> None:
        if not self.lost.is_set():
            log.error("robot link %s lost its lease: %s; it stops publishing", self.holder, why)
        self._valid_until = 0.0
        self.lost.set()

    def _redis_ok(self) -> None:
        if self._redis_down:
            log.warning("robot link %s reaches Redis again", self.holder)
            self._redis_down = False

    def _redis_failed(self) -> None:
        if not self._redis_down:
            log.exception("robot link %s cannot reach Redis for its lease", self.holder)
            self._redis_down = True
