"""Coalescing fan-out: forward each topic to browsers at its UI rate, latest value wins.

One sender task drains an ordered outbox, so a slow channel layer never blocks the
link's receive path and memory stays bounded: a coalesced topic holds one slot, and
every-message topics (logs, events) hold at most ``max_backlog`` entries.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import time
from collections import OrderedDict
from collections.abc import Awaitable, Callable
from typing import Any

log = logging.getLogger(__name__)

Send = Callable[[Any], Awaitable[None]]

# A topic whose messages arrive at most this much of a period early counts as published at
# its UI rate and passes straight through.
JITTER_SLACK = 0.2


class Coalescer:
    def __init__(self, send: Send, *, loop: asyncio.AbstractEventLoop, max_backlog: int = 5000) -> None:
        self._send = send
        self._loop = loop
        self._max_backlog = max_backlog
        self._outbox: OrderedDict[Any, Any] = OrderedDict()
        self._last_sent: dict[str, float] = {}
        self._last_arrival: dict[str, float] = {}
        self._waiting: dict[str, Any] = {}  # key -> latest value held back by the rate limit
        self._timers: dict[str, asyncio.TimerHandle] = {}
        self._seq = itertools.count()
        self._wake = asyncio.Event()
        self._closed = False
        self._task = loop.create_task(self._drain())
        self.dropped = 0

    def offer(self, key: str, rate_hz: float | None, value: Any) -> None:
        if rate_hz is None:
            self._enqueue((key, next(self._seq)), value)
            return
        now = time.monotonic()
        previous = self._last_arrival.get(key)
        self._last_arrival[key] = now
        if key in self._timers:
            self._waiting[key] = value
            return
        gap = 1.0 / rate_hz
        # Judge an on-rate topic by its arrival gaps, not by the last release: holding a message
        # that is early only by jitter would push every later release back by as much, so one
        # late message would make the topic lag (up to a period) for as long as it runs.
        if previous is not None and now - previous >= gap * (1.0 - JITTER_SLACK):
            wait = 0.0
        else:
            wait = self._last_sent.get(key, 0.0) + gap - now
        if wait <= 0:
            self._release(key, value)
        else:
            self._waiting[key] = value
            self._timers[key] = self._loop.call_later(wait, self._on_timer, key)

    def _on_timer(self, key: str) -> None:
        self._timers.pop(key, None)
        value = self._waiting.pop(key, None)
        if value is not None:
            self._release(key, value)

    def _release(self, key: str, value: Any) -> None:
        self._last_sent[key] = time.monotonic()
        self._enqueue(key, value)

    def _enqueue(self, slot: Any, value: Any) -> None:
        if len(self._outbox) >= self._max_backlog and slot not in self._outbox:
            self._outbox.popitem(last=False)
            self.dropped += 1
            if self.dropped % 1000 == 1:
                log.warning("browser fan-out is behind: %d updates dropped so far", self.dropped)
        self._outbox[slot] = value
        self._wake.set()

    async def _drain(self) -> None:
        # Exit on a flag, not only on cancellation: redis-py may turn a cancel into a
        # ConnectionError, which the send's error handling would otherwise swallow.
        while not self._closed:
            await self._wake.wait()
            self._wake.clear()
            while self._outbox and not self._closed:
                _, value = self._outbox.popitem(last=False)
                try:
                    await self._send(value)
                except Exception:
                    log.exception("fan-out send failed")

    def close(self) -> None:
        self._closed = True
        self._wake.set()
        self._task.cancel()
        for timer in self._timers.values():
            timer.cancel()
