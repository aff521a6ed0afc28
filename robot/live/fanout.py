"""Coalescing fan-out: forward each topic to browsers at its UI rate, latest value wins.

One sender task drains an ordered outbox, so a slow channel layer never blocks the
link's receive path and memory stays bounded: a coalesced topic holds one slot, and
every-message topics (logs, events) hold at most ``max_backlog`` entries together, and at most
their own ``queue_length`` each when given one (the oldest of that topic dropped).
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import time
from collections import OrderedDict, deque
from collections.abc import Awaitable, Callable
from typing import Any

from cyborg_site.bucket import Bucket
from robot.supervisor import spawn

log = logging.getLogger(__name__)

Send = Callable[[Any], Awaitable[None]]
# Takes a value at once if it can (True), without waiting: the outbox is then skipped.
WriteNow = Callable[[Any], bool]

# A coalesced topic's message goes at once when it is the first of its period: it arrived at least
# 1 - JITTER_SLACK of a period after the previous one (a topic published at its UI rate, give or
# take jitter), or a token is left in a bucket of BURST refilled at the UI rate (the early one of
# two bunched together by a late one). Otherwise it waits, latest value wins, for the next token:
# a topic published faster than its UI rate reaches browsers at that rate.
BURST = 2.0
JITTER_SLACK = 0.2


class Coalescer:
    def __init__(self, send: Send, *, loop: asyncio.AbstractEventLoop, max_backlog: int = 5000,
                 write_now: WriteNow | None = None) -> None:
        self._send = send
        self._write_now = write_now
        self._loop = loop
        self._max_backlog = max_backlog
        self._outbox: OrderedDict[Any, Any] = OrderedDict()
        self._buckets: dict[str, Bucket] = {}
        self._last_arrival: dict[str, float] = {}
        self._waiting: dict[str, Any] = {}  # key -> latest value held back by the rate limit
        self._timers: dict[str, asyncio.TimerHandle] = {}
        self._queued: dict[str, deque[Any]] = {}  # key -> its every-message slots in the outbox, oldest first
        self._seq = itertools.count()
        self._wake = asyncio.Event()
        self._closed = False
        self._task = spawn(self._drain(), loop=loop)
        self.dropped = 0

    def offer(self, key: str, rate_hz: float | None, value: Any, queue_length: int = 0) -> None:
        """``value`` for ``key``: the latest within ``rate_hz``, or with None every one, of which at
        most ``queue_length`` (0: no limit of its own) wait to be sent, the oldest dropped."""
        if rate_hz is None:
            self._enqueue((key, next(self._seq)), value, queue_length)
            return
        now = time.monotonic()
        previous = self._last_arrival.get(key)
        self._last_arrival[key] = now
        if key in self._timers:
            self._waiting[key] = value
            return
        gap = 1.0 / rate_hz
        tokens = self._tokens(key, gap)
        if tokens >= 1.0 or (previous is not None and now - previous >= gap * (1.0 - JITTER_SLACK)):
            self._release(key, value)
        else:
            self._waiting[key] = value
            self._timers[key] = self._loop.call_later((1.0 - tokens) * gap, self._on_timer, key, gap)

    def _tokens(self, key: str, gap: float) -> float:
        bucket = self._buckets.get(key)
        if bucket is None:
            bucket = self._buckets[key] = Bucket(1.0 / gap, BURST)
        elif bucket.rate != 1.0 / gap:  # the key's rate changed: the new one counts from now
            bucket.level()
            bucket.rate = 1.0 / gap
        return bucket.level()

    def _on_timer(self, key: str, gap: float) -> None:
        self._timers.pop(key, None)
        value = self._waiting.pop(key, None)
        if value is not None:
            self._tokens(key, gap)  # about one by now; a timer's lateness is no reason to wait again
            self._release(key, value)

    def _release(self, key: str, value: Any) -> None:
        bucket = self._buckets[key]
        bucket.tokens = max(0.0, bucket.tokens - 1.0)  # one released on its period owes nothing
        self._enqueue(key, value)

    def _enqueue(self, slot: Any, value: Any, queue_length: int = 0) -> None:
        if not self._outbox and self._write_now is not None and self._write_now(value):
            return  # nothing queued before it: no task switch on the way out
        if isinstance(slot, tuple):  # every message of slot[0]
            queued = self._queued.setdefault(slot[0], deque())
            if queue_length and len(queued) >= queue_length:
                del self._outbox[queued.popleft()]
                self._count_drop()
            queued.append(slot)
        if len(self._outbox) >= self._max_backlog and slot not in self._outbox:
            self._forget(self._outbox.popitem(last=False)[0])
            self._count_drop()
        self._outbox[slot] = value
        self._wake.set()

    def _forget(self, slot: Any) -> None:
        """``slot`` left the outbox (sent or dropped): an every-message one was its key's oldest."""
        if isinstance(slot, tuple):
            queued = self._queued.get(slot[0])
            if queued and queued[0] == slot:
                queued.popleft()
                if not queued:
                    del self._queued[slot[0]]

    def _count_drop(self) -> None:
        self.dropped += 1
        if self.dropped % 1000 == 1:
            log.warning("fan-out is behind: %d updates dropped so far", self.dropped)

    async def _drain(self) -> None:
        while not self._closed:  # until close(), which also cancels it
            await self._wake.wait()
            self._wake.clear()
            while self._outbox and not self._closed:
                slot, value = self._outbox.popitem(last=False)
                self._forget(slot)
                try:
                    await self._send(value)
                except Exception:
                    log.exception("fan-out send failed")

    def close(self) -> asyncio.Task:
        """Stop: the sender's task, cancelled (to await its end)."""
        self._closed = True
        self._wake.set()
        self._task.cancel()
        for timer in self._timers.values():
            timer.cancel()
        return self._task
