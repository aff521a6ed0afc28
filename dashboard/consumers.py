"""The live websocket: link status and the topics a page watches."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Iterable
from typing import Any

from channels.db import database_sync_to_async
from channels.generic.websocket import AsyncJsonWebsocketConsumer

from cyborg_site.roles import is_operator, roles_cached
from dashboard.fastdispatch import NoDatabaseHopMixin
from dashboard.services_watch import ensure_watching
from history.access import refusal, refused_topics
from robot import interface as ri
from robot.commands.reconnect import reconnect
from robot.link.bus import RobotError
from robot.link.topicwatch import TopicRefused, local_watches
from robot.link.watching import ECHO_PREFIX, echo_key, is_echo_key
from robot.live.feed import alocal_hub, keeps_every_message
from robot.live.frames import status_text, update_fragment
from robot.live.groups import STATUS_KEY
from robot.live.hub import FRAMES_EXTENSION
from robot.live.keys import SERVER_KEYS, upstream_topics, watchable_keys
from robot.live.state import get_store
from robot.supervisor import spawn

log = logging.getLogger(__name__)

UNAUTHENTICATED = 4401
# How soon a viewer stops getting a topic an admin has just marked sensitive.
RECHECK_S = 2.0


def _topic_names(key: str) -> list[str]:
    """The robot topics a watchable key shows (none for keys the server writes)."""
    return [ri.topic(k).name for k in upstream_topics(key)]


class LiveConsumer(NoDatabaseHopMixin, AsyncJsonWebsocketConsumer):
    """Thin: topic updates and link status come from this process's hub (robot.live.hub), never
    through the channel layer, and nothing here touches the database but the reconnect check and,
    for a viewer asking to watch, the sensitive topics."""

    channel_layer_alias = "none"  # not configured: this consumer gets no per-socket channel
    db_free_types = frozenset({"websocket.connect", "websocket.receive", "websocket.disconnect"})
    _rechecking: asyncio.Future | None = None

    async def connect(self) -> None:
        user = self.scope.get("user")
        if user is None or not user.is_authenticated:
            await self.close(code=UNAUTHENTICATED)
            return
        await self.accept()
        self.hub = await alocal_hub()
        ensure_watching(self.hub)
        try:
            status = (await get_store().aget_many([STATUS_KEY])).get(STATUS_KEY)
        except Exception:  # Redis is away: the page still opens, and its status says so
            status = None
        await self.send(text_data=self.hub.status_frame(status_text(status)))
        # Under Daphne: frames written straight to the connection (server.patches.direct_frames).
        writer = self.scope.get("extensions", {}).get(FRAMES_EXTENSION, {}).get("writer")
        self.socket = self.hub.attach(self._send_text, writer)

    async def _send_text(self, text: str) -> None:
        await self.base_send({"type": "websocket.send", "text": text})

    async def disconnect(self, code: int) -> None:
        if self._rechecking is not None:
            self._rechecking.cancel()
        if hasattr(self, "socket"):
            self.hub.detach(self.socket)
            await local_watches().drop(self.socket)

    async def receive_json(self, content: Any, **kwargs: Any) -> None:
        action = content.get("action") if isinstance(content, dict) else None
        if action == "watch":
            await self._watch(content.get("keys"))
        elif action == "unwatch":
            await self._unwatch(content.get("keys"))
        elif action == "reconnect":
            await self._reconnect()
        elif action == "watch_topic":
            await self._watch_topic(content.get("topic"))
        elif action == "unwatch_topic":
            await self._unwatch_topic(content.get("topic"))
        else:
            await self.send_json({"kind": "error", "message": f"Unknown action {action!r}"})

    async def _watch(self, keys: Any) -> None:
        allowed = watchable_keys()
        if not isinstance(keys, list) or not all(isinstance(k, str) for k in keys):
            await self.send_json({"kind": "error", "message": "watch needs a list of topic keys"})
            return
        shows = {k: _topic_names(k) for k in keys if k in allowed}
        refused = set(await self._refused([t for names in shows.values() for t in names]))
        allowed -= {k for k, names in shows.items() if refused.intersection(names)}
        unknown = [k for k in keys if k not in allowed]
        if unknown:
            await self.send_json({"kind": "error", "message": f"Cannot watch: {', '.join(unknown)}"})
        new = [k for k in dict.fromkeys(keys) if k in allowed and k not in self.socket.keys]
        if new:
            await self._hold_upstream([*self.socket.keys, *new])
        await self._snapshot(new)
        self._keep_rechecking()

    async def _unwatch(self, keys: Any) -> None:
        if not isinstance(keys, list) or not all(isinstance(k, str) for k in keys):
            await self.send_json({"kind": "error", "message": "unwatch needs a list of topic keys"})
            return
        self.hub.unwatch(self.socket, keys)
        for key in keys:
            if is_echo_key(key):
                await local_watches().unwatch(self.socket, key.removeprefix(ECHO_PREFIX))
        await self._hold_upstream(self.socket.keys)

    async def _hold_upstream(self, keys: Iterable[str]) -> None:
        """Hold at the link the robot topics these keys need that it does not always subscribe to
        (server-written keys need none, a map overlay its sources); let go of the rest."""
        needed = {t for key in keys if not is_echo_key(key) for t in upstream_topics(key) if not ri.topic(t).monitor}
        try:
            await local_watches().hold(self.socket, needed)
        except RobotError as exc:
            await self.send_json({"kind": "error", "message": exc.message})

    async def _watch_topic(self, name: Any) -> None:
        """Any topic of the robot's, by name (the topics page): summarised, at most a few times a second."""
        if isinstance(name, str) and await self._refused([name]):
            await self.send_json({"kind": "error", "code": "forbidden", "topic": name[:300], "message": refusal(name)})
            return
        key = echo_key(name) if isinstance(name, str) else ""
        first = bool(key) and key not in self.socket.keys
        if first:  # listening before the link answers: it sends a latched topic's one message at once
            self.hub.watch(self.socket, [key])
        try:
            await local_watches().watch(self.socket, name)
        except TopicRefused as exc:
            await self.send_json({"kind": "error", "code": exc.code, "topic": str(name)[:300], "message": exc.message})
            if exc.code != "offline":
                if first:
                    self.hub.unwatch(self.socket, [key])
                return
        if first and key not in self.socket.pending:  # else a live value is already on its way
            await self._snapshot([key])
        await self.send_json({"kind": "watching", "topic": name, "key": key})
        self._keep_rechecking()

    async def _unwatch_topic(self, name: Any) -> None:
        if not isinstance(name, str):
            await self.send_json({"kind": "error", "message": "unwatch_topic needs a topic name"})
            return
        self.hub.unwatch(self.socket, [echo_key(name)])
        await local_watches().unwatch(self.socket, name)

    async def _refused(self, topics: list[str]) -> list[str]:
        """Those of ``topics`` this socket's person may not watch (history.access): no query for an
        operator whose roles are known, one in a thread for anyone else."""
        user = self.scope["user"]
        if not topics or (roles_cached(user) and is_operator(user)):
            return []
        return await database_sync_to_async(refused_topics)(user, topics)

    def _keep_rechecking(self) -> None:
        user = self.scope["user"]
        if roles_cached(user) and is_operator(user):
            return
        if self._rechecking is None or self._rechecking.done():
            self._rechecking = spawn(self._recheck())

    async def _recheck(self) -> None:
        """While this person watches robot topics: every ``RECHECK_S``, end the watches of those an
        admin has since marked sensitive (a watch is checked when it starts; this is for later)."""
        while self.socket.keys:
            await asyncio.sleep(RECHECK_S)
            shows = {key: [key.removeprefix(ECHO_PREFIX)] if is_echo_key(key) else _topic_names(key)
                     for key in self.socket.keys}
            try:
                refused = set(await database_sync_to_async(refused_topics)(
                    self.scope["user"], [t for names in shows.values() for t in names], max_age_s=RECHECK_S / 2))
            except Exception:  # the database is away: look again next time
                log.warning("could not look again at the sensitive topics", exc_info=True)
                continue
            for key, names in shows.items():
                for name in refused.intersection(names):
                    if is_echo_key(key):
                        await self._unwatch_topic(name)
                    else:
                        await self._unwatch([key])
                    await self.send_json({"kind": "error", "code": "forbidden", "topic": name, "key": key,
                                          "message": refusal(name)})

    async def _snapshot(self, keys: list[str]) -> None:
        """Watch ``keys`` and queue their stored values, never older than a live update already queued."""
        socket = self.socket
        socket.tracking = {}
        self.hub.watch(socket, keys)
        try:
            store = get_store()
            recent = {k for k in keys if k not in SERVER_KEYS and not is_echo_key(k) and ri.topic(k).recent}
            latest = await store.aget_many([k for k in keys if k not in recent])
            for key in keys:
                every = keeps_every_message(key)
                entries: list[dict[str, Any] | None] = [*await store.aget_recent(key)] if key in recent \
                    else [latest.get(key)]
                live = socket.tracking.get(key)
                for entry in entries:
                    if not entry:
                        continue
                    t = float(entry["t"])
                    if live and (t >= min(live) if every else t <= max(live)):
                        continue  # this one (or a newer value) is already on its way
                    self.hub.offer(socket, key, update_fragment(entry), t, every=every)
        finally:
            socket.tracking = None

    async def _reconnect(self) -> None:
        try:
            await reconnect(user=self.scope["user"], source="websocket")
            await self.send_json({"kind": "notice", "message": "Reconnecting to the robot…"})
        except RobotError as exc:
            await self.send_json({"kind": "error", "message": exc.message})
