"""The live websocket: link status and the topics a page watches."""

from __future__ import annotations

from typing import Any

from channels.db import database_sync_to_async
from channels.generic.websocket import AsyncJsonWebsocketConsumer

from cyborg_site.roles import is_operator
from dashboard.fastdispatch import NoDatabaseHopMixin
from dashboard.live import live_frame, status_frame
from robot import interface as ri
from robot.link.bus import RobotError, arequest
from robot.live.groups import STATUS_GROUP, STATUS_KEY, topic_group
from robot.live.keys import SERVER_KEYS, watchable_keys
from robot.live.state import get_store

UNAUTHENTICATED = 4401


class LiveConsumer(NoDatabaseHopMixin, AsyncJsonWebsocketConsumer):
    db_free_types = frozenset({"robot.update", "robot.status"})

    async def connect(self) -> None:
        user = self.scope.get("user")
        if user is None or not user.is_authenticated:
            await self.close(code=UNAUTHENTICATED)
            return
        self.watching: set[str] = set()
        self.can_command = await database_sync_to_async(is_operator)(user)
        await self.channel_layer.group_add(STATUS_GROUP, self.channel_name)
        await self.accept()
        status = (await get_store().aget_many([STATUS_KEY])).get(STATUS_KEY)
        await self.send_json(status_frame(status))

    async def disconnect(self, code: int) -> None:
        for key in getattr(self, "watching", ()):
            await self.channel_layer.group_discard(topic_group(key), self.channel_name)
        await self.channel_layer.group_discard(STATUS_GROUP, self.channel_name)

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
        new = [k for k in keys if k in allowed and k not in self.watching]
        for key in new:
            await self.channel_layer.group_add(topic_group(key), self.channel_name)
            self.watching.add(key)
        for key in new:
            if key in SERVER_KEYS:  # written by the server itself: no ROS topic to subscribe
                continue
            topic = ri.topic(key)
            if not topic.monitor:  # subscribed on first demand, once for every watcher
                try:
                    await arequest("subscribe", topic=topic.name, msg_type=topic.type, timeout=2)
                except RobotError as exc:
                    await self.send_json({"kind": "error", "message": exc.message})
        store = get_store()
        recent = {k for k in new if k not in SERVER_KEYS and ri.topic(k).recent}
        latest = await store.aget_many([k for k in new if k not in recent])
        for key in new:
            entries = await store.aget_recent(key) if key in recent else [latest.get(key)]
            for entry in entries:
                if entry:
                    await self.send_json(live_frame(entry))

    async def _reconnect(self) -> None:
        if not self.can_command:
            await self.send_json({"kind": "error", "message": "Only operators can reconnect the robot link."})
            return
        try:
            await arequest("reconnect", timeout=2)
            await self.send_json({"kind": "notice", "message": "Reconnecting to the robot…"})
        except RobotError as exc:
            await self.send_json({"kind": "error", "message": exc.message})

    async def robot_update(self, event: dict[str, Any]) -> None:
        await self.send_json(live_frame(event))

    async def robot_status(self, event: dict[str, Any]) -> None:
        await self.send_json(status_frame(event))
