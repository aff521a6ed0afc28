"""``/ws/teleop/``: the drive page's socket. The protocol lives in ``robot.teleop.driver``."""

from __future__ import annotations

import json
from typing import Any

from channels.db import database_sync_to_async
from channels.generic.websocket import AsyncJsonWebsocketConsumer

from cyborg_site.roles import is_operator
from dashboard.consumers import UNAUTHENTICATED
from dashboard.fastdispatch import NoDatabaseHopMixin
from dashboard.revocation import close_if_revoked
from robot.live.groups import LOCK_GROUP, person_group
from robot.teleop.driver import Driver
from robot.teleop.driving import LockEvent


class TeleopConsumer(NoDatabaseHopMixin, AsyncJsonWebsocketConsumer):
    # Stick input must not queue behind other database work; lock audits hop themselves.
    db_free_types = frozenset({"websocket.receive", "teleop.lock"})
    driver: Driver | None = None

    async def connect(self) -> None:
        user = self.scope.get("user")
        if user is None or not user.is_authenticated:
            await self.close(code=UNAUTHENTICATED)
            return
        can_drive = await database_sync_to_async(is_operator)(user)
        self.driver = Driver(user=user, owner=self.channel_name, can_drive=can_drive, send=self.send_json)
        await self.channel_layer.group_add(LOCK_GROUP, self.channel_name)
        await self.channel_layer.group_add(person_group(user.pk), self.channel_name)
        await self.accept()
        await self.driver.start()

    async def disconnect(self, code: int) -> None:
        if self.driver is None:
            return
        await self.driver.close()
        await self.channel_layer.group_discard(LOCK_GROUP, self.channel_name)
        await self.channel_layer.group_discard(person_group(self.scope["user"].pk), self.channel_name)

    @classmethod
    async def decode_json(cls, text_data: str) -> Any:
        try:
            return json.loads(text_data)
        except ValueError:
            return None  # answered with an error frame, the socket stays open

    async def receive_json(self, content: Any, **kwargs: Any) -> None:
        assert self.driver is not None
        await self.driver.handle(content)

    async def access_changed(self, event: dict[str, Any]) -> None:
        """The person's access changed: stop driving and close if they may no longer drive (or be here)."""
        if self.driver is not None:  # (its close: zero if it moved, the drive lock given back, audited)
            await close_if_revoked(self, event, operator=self.driver.can_drive, end=self.driver.close)

    async def teleop_lock(self, event: LockEvent) -> None:
        if self.driver is not None:
            await self.driver.on_lock_event(event)
