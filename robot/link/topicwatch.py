"""Which topics this web process's pages watch, held at the robot link by one lease per process.

A page's socket opens a topic (``watch``) and closes it (``unwatch``, or by going away: ``drop``).
The registry topics its live keys need (a map overlay's) it holds the same way (``hold``), only
not echoed. The first socket of the process on a topic, and the last one leaving it, send the
process's whole set to the link (``topics_watch``); a supervised loop renews it every
``RENEW_S``, so a link that restarted (or took over) has every lease back within seconds
and a dead web process's leases run out by themselves. Syncs go one at a time so the link sees
them in order.
"""

from __future__ import annotations

import asyncio
import logging
import os
import socket
import uuid
import weakref
from collections.abc import Iterable
from typing import Any

from robot import interface as ri
from robot.link.bus import RobotError, RobotOffline, arequest
from robot.link.holders import RENEW_S
from robot.link.watching import TopicRefused
from robot.supervisor import supervise

log = logging.getLogger(__name__)

SYNC_TIMEOUT_S = 3.0


class LocalWatches:
    def __init__(self) -> None:
        self.holder = f"{socket.gethostname()}:{os.getpid()}:{uuid.uuid4().hex[:8]}"
        self.watchers: dict[str, set[Any]] = {}  # topic -> the sockets watching it
        self.holding: dict[str, set[Any]] = {}  # registry topic key -> the sockets whose live keys need it
        self.whole: dict[str, set[Any]] = {}  # topic -> the sockets taking its every message whole (front door)
        self._lock = asyncio.Lock()
        self._renewing: asyncio.Task | None = None

    async def watch(self, watcher: Any, name: str, *, whole: bool = False) -> None:
        """``watcher`` watches ``name`` (summarised, or with ``whole`` every message whole); TopicRefused
        when the name is bad or the robot has no such topic. While the robot is offline the watch stays
        and takes effect when it returns."""
        problem = ri.topic_name_problem(name)
        if problem:
            raise TopicRefused("invalid", problem)
        table = self.whole if whole else self.watchers
        first = name not in table
        table.setdefault(name, set()).add(watcher)
        self._ensure_renewing()
        if not first:
            return
        try:
            refused = await self._sync()
        except RobotOffline as exc:
            raise TopicRefused("offline", exc.message) from None
        except RobotError as exc:
            _leave(table, watcher, name)
            raise TopicRefused(exc.code, exc.message) from None
        if name in refused:
            _leave(table, watcher, name)
            raise TopicRefused(refused[name].get("code", "failed"), refused[name].get("error", "refused"))

    async def unwatch(self, watcher: Any, name: str, *, whole: bool = False) -> None:
        if _leave(self.whole if whole else self.watchers, watcher, name):
            await self._sync_quietly()

    async def hold(self, watcher: Any, keys: Iterable[str]) -> None:
        """``watcher``'s live keys now need exactly the registry topics ``keys`` held at the link.
        RobotError when the link cannot be told of a topic newly needed."""
        wanted = set(keys)
        before = set(self.holding)
        for key in wanted:
            self.holding.setdefault(key, set()).add(watcher)
        for key in [k for k, watchers in self.holding.items() if k not in wanted and watcher in watchers]:
            _leave(self.holding, watcher, key)
        if set(self.holding) - before:
            self._ensure_renewing()
            await self._sync()
        elif set(self.holding) != before:
            await self._sync_quietly()

    async def drop(self, watcher: Any) -> None:
        """``watcher`` went away: let go of everything it watched and held."""
        gone = [name for table in (self.watchers, self.whole) for name in list(table) if _leave(table, watcher, name)]
        released = [key for key in list(self.holding) if _leave(self.holding, watcher, key)]
        if gone or released:
            await self._sync_quietly()

    async def _sync(self) -> dict[str, dict[str, str]]:
        async with self._lock:
            reply = await arequest("topics_watch", holder=self.holder, topics=sorted(self.watchers),
                                   held=sorted(self.holding), whole=sorted(self.whole), timeout=SYNC_TIMEOUT_S)
        return dict(reply.get("refused") or {})

    async def _sync_quietly(self) -> None:
        try:
            await self._sync()
        except RobotError as exc:
            log.info("could not tell the robot link which topics are watched (renewed shortly): %s", exc.message)

    def _ensure_renewing(self) -> None:
        if self._renewing is None or self._renewing.done():
            self._renewing = supervise(f"topics.renew.{self.holder[-8:]}", self._renew_forever)

    async def _renew_forever(self) -> None:
        while self.watchers or self.holding or self.whole:
            await asyncio.sleep(RENEW_S)
            if self.watchers or self.holding or self.whole:
                await self._sync_quietly()


def _leave(table: dict[str, set[Any]], watcher: Any, key: str) -> bool:
    """Remove ``watcher`` from ``table[key]``; True when it was the last one there in this process."""
    watchers = table.get(key)
    if watchers is None or watcher not in watchers:
        return False
    watchers.discard(watcher)
    if watchers:
        return False
    del table[key]
    return True


_local: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, LocalWatches] = weakref.WeakKeyDictionary()


def local_watches() -> LocalWatches:
    """This process's watches (one per event loop: tests run several)."""
    loop = asyncio.get_running_loop()
    found = _local.get(loop)
    if found is None:
        found = _local[loop] = LocalWatches()
    return found
