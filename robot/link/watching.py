"""Any topic a page opens, where the link runs: one upstream subscription however many pages watch.

Each web process holds one lease per topic its pages watch (``topics_watch``: the process's whole
set of watched topics, sent on every change and renewed, ``robot.link.holders``); a lease not
renewed is gone (its web process died). The link holds the upstream
subscription while any lease lives; when the last one goes it waits ``TOPICS_IDLE_GRACE_S`` and
then lets go (the subscription stays if the registry, the recorder or anyone else still holds it).
The same request also holds, by registry key, the robot topics the pages' live keys need that
the link does not always subscribe to (a map overlay's laser, costmaps, transforms): held alike,
never echoed.

While a topic is watched every message is offered to a coalescer (at most ``TOPICS_ECHO_MAX_HZ``,
latest value wins), summarised (``robot.live.summary``) and announced once under its echo key to
every web process's hub. ``topics_list`` answers the robot's topics with types and publishers
(rosapi), ``topics_rate`` measures a topic's rate over a short window.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import time
from collections.abc import Awaitable
from typing import Any, cast

import numpy as np
from django.conf import settings

from robot import interface as ri
from robot.link.connection import RobotLink, one_per_link, register_start
from robot.link.holders import Leases
from robot.link.serving import register_operation
from robot.live import feed
from robot.live.announce import aannounce
from robot.live.fanout import Coalescer
from robot.live.groups import LinkReply, LinkRequest, TopicUpdate
from robot.live.summary import summarise
from robot.supervisor import supervise

log = logging.getLogger(__name__)

SWEEP_S = 0.1
HOLDER = "watch"  # this module's hold on the link's upstream subscriptions
ECHO_PREFIX = "topic:"
WHOLE_PREFIX = "whole:"
LIST_CACHE_S = 2.0
BULKY_ITEMS = 10_000
RATE_WINDOW_S = (0.5, 10.0)  # the shortest and longest measuring window a request may ask for
_rate_ids = itertools.count()


def echo_key(name: str) -> str:
    """The live key under which a watched topic's messages reach the pages."""
    return ECHO_PREFIX + name


def is_echo_key(key: str) -> bool:
    return key.startswith(ECHO_PREFIX)


def whole_key(name: str) -> str:
    """The live key under which a topic's every message goes, whole (the front door's rosbridge clients)."""
    return WHOLE_PREFIX + name


class TopicRefused(Exception):
    """A topic nobody may watch: a bad name, none of the robot's, or the robot offline (``code`` says which)."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(message)
        self.code = code
        self.message = message


class Watches:
    """The leases of one link and what they hold."""

    def __init__(self, link: RobotLink) -> None:
        self.link = link
        self.leases = Leases()  # topic -> holders: echoed to pages
        self.holds = Leases()  # the same for registry topics held for live keys
        self.whole = Leases()  # the same for topics sent whole, every message
        self.idle_since: dict[str, float] = {}  # topic -> when its last lease went (the grace period runs)
        self.types: dict[str, str] = {}
        self.counters: dict[int, tuple[str, list[float]]] = {}  # rate measurements: id -> (topic, receive times)
        # The last message of every subscribed topic (a reference, summarised only when needed): a page that
        # opens a topic someone else already holds still sees its latched or rare message at once.
        self.last: dict[str, TopicUpdate] = {}
        self.summarised: set[str] = set()  # the topics whose last message is kept summarised (bulky)
        # The last message of each topic the interface marks latched, whole even when bulky (a map): a
        # front-door tool watching it after it came gets it at once, as from the robot's rosbridge.
        self.latched: dict[str, TopicUpdate] = {}
        self._listing: tuple[float, list[dict[str, Any]]] | None = None
        assert link.dial.loop is not None
        self.coalescer = Coalescer(self._send, loop=link.dial.loop)
        link.listeners.append(self.offer)
        link.keep(supervise("link.topic-watch", self._sweep_forever))

    # --- leases ----------------------------------------------------------------------

    async def sync(self, holder: str, topics: list[str], held: list[str] | None = None,
                   whole: list[str] | None = None) -> dict[str, dict[str, str]]:
        """``holder`` now watches exactly ``topics`` (summarised), ``whole`` (every message whole) and
        holds exactly the registry topics with the keys ``held``; returns the ones refused: name (or
        key) -> {code, error}."""
        wanted = list(dict.fromkeys(topics))
        entire = list(dict.fromkeys(whole or []))
        refused: dict[str, dict[str, str]] = {}
        kept = self._registry_topics(held or [], refused)
        self.leases.keep_only(holder, wanted)
        self.holds.keep_only(holder, kept)
        self.whole.keep_only(holder, entire)
        for table, names in ((self.leases, wanted), (self.whole, entire)):
            for name in names:
                try:
                    msg_type = await self.resolve(name)
                except TopicRefused as exc:
                    refused[name] = {"code": exc.code, "error": exc.message}
                    continue
                if msg_type in ri.SOUND_TYPES:
                    refused[name] = {"code": "forbidden", "error": f"{name} carries sound: listen on the drive "
                                                                   "page (operators; audited)"}
                    continue
                new = name not in table
                self._lease(table, name, msg_type, holder)
                if new and table is self.whole and name in self.latched:
                    self.coalescer.offer(whole_key(name), None, self.latched[name])
                elif new and name in self.last:
                    if table is self.whole:
                        if name not in self.summarised:
                            self.coalescer.offer(whole_key(name), None, {**self.last[name], "key": whole_key(name)})
                    else:
                        self.coalescer.offer(echo_key(name), settings.TOPICS_ECHO_MAX_HZ, self.last[name])
        for name, msg_type in kept.items():
            self._lease(self.holds, name, msg_type, holder)
        self.sweep()
        return refused

    def _lease(self, table: Leases, name: str, msg_type: str, holder: str) -> None:
        table.renew(name, holder)
        self.idle_since.pop(name, None)
        self.link.subscriptions.subscribe(name, msg_type, holder=HOLDER)

    @staticmethod
    def _registry_topics(keys: list[str], refused: dict[str, dict[str, str]]) -> dict[str, str]:
        """The registry's topics with these keys (name -> type); the rest into ``refused``."""
        found: dict[str, str] = {}
        for key in keys:
            try:
                topic = ri.topic(key)
            except KeyError:
                refused[key] = {"code": "invalid", "error": f"no topic {key!r} in the registry"}
                continue
            if topic.type in ri.SOUND_TYPES:
                refused[key] = {"code": "forbidden", "error": f"{topic.name} carries sound"}
                continue
            found[topic.name] = topic.type
        return found

    async def resolve(self, name: str) -> str:
        """The topic's type from the robot (rosapi), cached; TopicRefused when it is no topic of the robot's."""
        problem = ri.topic_name_problem(name)
        if problem:
            raise TopicRefused("invalid", problem)
        known = self.types.get(name)
        if known:
            return known
        reply = await self.link.requests.call(ri.service("rosapi_topic_type"), {"topic": name})
        if not reply.get("ok"):
            raise TopicRefused(reply.get("error_code", "failed"), reply.get("error", "rosapi did not answer"))
        msg_type = str((reply.get("values") or {}).get("type") or "")
        if not msg_type:
            raise TopicRefused("not_found", f"The robot has no topic {name}")
        self.types[name] = msg_type
        return msg_type

    def sweep(self) -> None:
        now = time.monotonic()
        for name in [*self.leases.expire(), *self.holds.expire(), *self.whole.expire()]:
            if name not in self.leases and name not in self.holds and name not in self.whole:
                self.idle_since[name] = now
        grace = settings.TOPICS_IDLE_GRACE_S
        for name, since in list(self.idle_since.items()):
            if now - since >= grace:
                del self.idle_since[name]
                self.link.subscriptions.unsubscribe(name, holder=HOLDER)
                if name not in self.link.subscriptions.subscribed:
                    self.last.pop(name, None)
                    self.latched.pop(name, None)
                log.info("nobody watches %s any more: let go of its subscription", name)

    async def _sweep_forever(self) -> None:
        while True:
            await asyncio.sleep(SWEEP_S)
            self.sweep()

    # --- messages (on the link's loop, for every message of every subscribed topic) ---

    def offer(self, name: str, msg_type: str, msg: dict[str, Any], t: float) -> None:
        for topic, times in self.counters.values():
            if topic == name:
                times.append(t)
        whole: TopicUpdate = {"type": "robot.update", "key": whole_key(name), "topic": name, "msg_type": msg_type,
                              "msg": msg, "t": t}
        if name in self.whole:  # every message, whole, for the front door's clients (paced per client)
            self.coalescer.offer(whole_key(name), None, whole)
        if name in ri.latched_names():
            self.latched[name] = whole
        if _bulky(msg):  # never keep a whole map or costmap alive just in case someone opens it
            msg = summarise(msg)
            self.summarised.add(name)
        else:
            self.summarised.discard(name)
        update: TopicUpdate = {"type": "robot.update", "key": echo_key(name), "topic": name,
                               "msg_type": msg_type, "msg": msg, "t": t}
        self.last[name] = update
        if name in self.leases:
            self.coalescer.offer(update["key"], settings.TOPICS_ECHO_MAX_HZ, update)

    async def _send(self, update: TopicUpdate) -> None:
        event = dict(update)
        if update["key"].startswith(WHOLE_PREFIX):
            # Sent first (a tool's latency is the store's round trip shorter), then kept for a later
            # subscriber's first message (a latched topic's only one), unless bulky.
            await feed.announce(event)
            if not _bulky(update["msg"]):
                await self.link.store.aput(update["key"], event)
            return
        event["msg"] = summarise(update["msg"])
        await aannounce(update["key"], event, store=self.link.store)

    # --- what the robot has ----------------------------------------------------------

    async def listing(self) -> list[dict[str, Any]]:
        """Every topic of the robot's: name, type, publishers (rosapi) and whether the link holds it."""
        if self._listing is not None and time.monotonic() - self._listing[0] < LIST_CACHE_S:
            found = self._listing[1]
        else:
            reply = await self.link.requests.call(ri.service("rosapi_topics"))
            if not reply.get("ok"):
                raise TopicRefused(reply.get("error_code", "failed"), reply.get("error", "rosapi did not answer"))
            values = reply.get("values") or {}
            names, types = list(values.get("topics") or []), list(values.get("types") or [])
            self.types.update({n: t for n, t in zip(names, types, strict=False) if t})
            publishers = await asyncio.gather(*(self._publishers(n) for n in names))
            found = [{"name": n, "type": self.types.get(n, ""), "publishers": p}
                     for n, p in zip(names, publishers, strict=True)]
            self._listing = (time.monotonic(), found)
        subscribed = self.link.subscriptions.subscribed
        return [{**t, "subscribed": t["name"] in subscribed} for t in found]

    async def _publishers(self, name: str) -> list[str] | None:
        reply = await self.link.requests.call(ri.service("rosapi_publishers"), {"topic": name})
        if not reply.get("ok"):
            return None  # an older rosapi without the service: shown as unknown
        return [str(p) for p in (reply.get("values") or {}).get("publishers") or []]

    async def rate(self, name: str, window_s: float) -> dict[str, Any]:
        """Messages per second on ``name`` over ``window_s`` (from the gaps between receive times,
        so a latched message delivered at subscription does not count as a burst)."""
        msg_type = await self.resolve(name)
        rate_id = next(_rate_ids)
        holder = f"rate:{rate_id}"
        times: list[float] = []
        self.counters[rate_id] = (name, times)
        self.link.subscriptions.subscribe(name, msg_type, holder=holder)
        try:
            await asyncio.sleep(window_s)
        finally:
            del self.counters[rate_id]
            self.link.subscriptions.unsubscribe(name, holder=holder)
        hz = (len(times) - 1) / (times[-1] - times[0]) if len(times) >= 2 and times[-1] > times[0] else 0.0
        return {"topic": name, "type": msg_type, "hz": round(hz, 3), "messages": len(times), "window_s": window_s}


def _bulky(msg: dict[str, Any]) -> bool:
    """A message with a huge top-level array or text (a grid's cells, audio bytes): cheap to tell."""
    return any(isinstance(v, list | str | np.ndarray) and len(v) > BULKY_ITEMS for v in msg.values())


watches_of = one_per_link(Watches)


async def _answer(values: Awaitable[Any]) -> LinkReply:
    try:
        return {"ok": True, "values": await values}
    except TopicRefused as exc:
        return {"ok": False, "error_code": exc.code, "error": exc.message}


async def _watch(link: RobotLink, request: LinkRequest) -> LinkReply:
    lists = [request.get("topics"), request.get("held") or [], request.get("whole") or []]
    if not all(isinstance(x, list) and all(isinstance(n, str) for n in x) for x in lists):
        return {"ok": False, "error_code": "invalid", "error": "topics_watch needs lists of topic names and keys"}
    topics, held, whole = (cast(list[str], x) for x in lists)
    refused = await watches_of(link).sync(str(request.get("holder") or ""), topics, held, whole)
    return {"ok": True, "refused": refused}


async def _rate(link: RobotLink, request: LinkRequest) -> LinkReply:
    low, high = RATE_WINDOW_S
    window = min(high, max(low, float(request.get("window_s") or 2.0)))
    return await _answer(watches_of(link).rate(str(request.get("topic") or ""), window))


def install() -> None:
    register_start(watches_of)  # listening before the first message: a latched one is never missed
    register_operation("topics_watch", _watch)
    register_operation("topics_list", lambda link, request: _answer(watches_of(link).listing()))
    register_operation("topics_rate", _rate)
