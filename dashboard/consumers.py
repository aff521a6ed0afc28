"""The live websocket: link status and the topics a page watches."""

from __future__ import annotations

from typing import Any

from channels.db import database_sync_to_async
from channels.generic.websocket import AsyncJsonWebsocketConsumer

from cyborg_site.roles import is_operator
from dashboard.fastdispatch import NoDatabaseHopMixin
from robot import interface as ri
from robot.link.bus import RobotError, arequest
from robot.live.feed import keeps_every_message, local_hub
from robot.live.frames import status_text, update_fragment
from robot.live.groups import STATUS_KEY
from robot.live.keys import SERVER_KEYS, watchable_keys
from robot.live.state import get_store

UNAUTHENTICATED = 4401


class LiveConsumer(NoDatabaseHopMixin, AsyncJsonWebsocketConsumer):
    """Thin: topic updates and link status come from this process's hub (robot.live.hub), never
    through the channel layer, and nothing here touches the database but the reconnect check."""

    channel_layer_alias = "none"  # not configured: this consumer gets no per-socket channel
    db_free_types = frozenset({"websocket.connect", "websocket.receive", "websocket.disconnect"})

    async def connect(self) -> None:
        user = self.scope.get("user")
        if user is None or not user.is_authenticated:
            await self.close(code=UNAUTHENTICATED)
            return
        await self.accept()
        status = (await get_store().aget_many([STATUS_KEY])).get(STATUS_KEY)
        await self.send(text_data=status_text(status))
        self.hub = local_hub()
        self.socket = self.hub.attach(self._send_text)

    async def _send_text(self, text: str) -> None:
        await self.base_send({"type": "websocket.send", "text": text})

    async def disconnect(self, code: int) -> None:
        if hasattr(self, "socket"):
            self.hub.detach(self.socket)

    async def receive_json(self, content: Any, **kwargs: Any) -> None:
        action = content.get("action") if isinstance(content, dict) else None
        if action == "watch":
            await self._watch(content.get("keys"))
        elif action == "reconnect":
            await self._reconnect()
        else:
            await self.send_json({"kind": "error", "message": f"Unknown action {action!r}"})

    async def _watch(self, keys: Any) -> None:
        allowed = watchable_keys()
        if not isinstance(keys, list) or not all(isinstance(k, str) for k in keys):
            await self.send_json({"kind": "error", "message": "watch needs a list of topic keys"})
            return
        unknown = [k for k in keys if k not in allowed]
        if unknown:
            await self.send_json({"kind": "error", "message": f"Cannot watch: {', '.join(unknown)}"})
        new = [k for k in dict.fromkeys(keys) if k in allowed and k not in self.socket.keys]
        for key in new:
            if key in SERVER_KEYS:  # written by the server itself: no ROS topic to subscribe
                continue
            topic = ri.topic(key)
            if not topic.monitor:  # subscribed on first demand, once for every watcher
                try:
                    await arequest("subscribe", topic=topic.name, msg_type=topic.type, timeout=2)
                except RobotError as exc:
                    await self.send_json({"kind": "error", "message": exc.message})
        await self._snapshot(new)

    async def _snapshot(self, keys: list[str]) -> None:
        """Watch ``keys`` and queue their stored values, never older than a live update already queued."""
        socket = self.socket
        socket.tracking = {}
        self.hub.watch(socket, keys)
        try:
            store = get_store()
            recent = {k for k in keys if k not in SERVER_KEYS and ri.topic(k).recent}
            latest = await store.aget_many([k for k in keys if k not in recent])
            for key in keys:
                every = keeps_every_message(key)
                entries = await store.aget_recent(key) if key in recent else [latest.get(key)]
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
        if not await database_sync_to_async(is_operator)(self.scope["user"]):
            await self.send_json({"kind": "error", "message": "Only operators can reconnect the robot link."})
            return
        try:
            await arequest("reconnect", timeout=2)
            await self.send_json({"kind": "notice", "message": "Reconnecting to the robot…"})
        except RobotError as exc:
            await self.send_json({"kind": "error", "message": exc.message})
