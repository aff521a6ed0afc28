"""``/rosbridge/?ticket=…``: the front door for other ROS tools (rosbridge v2). The protocol lives in
``robot.frontdoor``; this socket lets a tool in by its single-use ticket only, hears the person's
access changes and the drive lock like the drive page, and audits each connect and disconnect."""

from __future__ import annotations

from typing import Any
from urllib.parse import parse_qs

from channels.db import database_sync_to_async
from channels.generic.websocket import AsyncWebsocketConsumer

from cyborg_site.client_address import client_address
from cyborg_site.roles import is_operator
from dashboard.consumers import UNAUTHENTICATED
from dashboard.fastdispatch import NoDatabaseHopMixin
from dashboard.revocation import close_if_revoked
from history.access import sensitive_topics
from robot.commands.audit_writer import writer
from robot.frontdoor.session import Session
from robot.frontdoor.tickets import ticket_redeem
from robot.live.groups import FRONTDOOR_GROUP, LOCK_GROUP, person_group
from robot.live.hub import FRAMES_EXTENSION
from robot.models import FrontDoorAllowance, FrontDoorPace
from robot.teleop.driving import LockEvent


def _configuration(user: Any) -> dict[str, Any]:
    """The admin's paces, allowed topics and services, and the topics this person may not watch:
    read when a tool connects and again when an admin changes them (its subscriptions then cost
    no database hop each)."""
    allowed = list(FrontDoorAllowance.objects.values_list("kind", "name"))
    return {"paces": dict(FrontDoorPace.objects.values_list("topic", "hz")),
            "topics": {name for kind, name in allowed if kind == FrontDoorAllowance.Kind.TOPIC},
            "services": {name for kind, name in allowed if kind == FrontDoorAllowance.Kind.SERVICE},
            "sensitive": set() if is_operator(user) else sensitive_topics()}


class FrontDoorConsumer(NoDatabaseHopMixin, AsyncWebsocketConsumer):
    db_free_types = frozenset({"websocket.receive", "teleop.lock"})
    session: Session | None = None

    async def connect(self) -> None:
        ticket = (parse_qs(self.scope.get("query_string", b"").decode("latin1")).get("ticket") or [""])[0]
        user = await database_sync_to_async(ticket_redeem)(ticket)
        if user is None:  # refused before the handshake completes: the tool sees a 403
            await self.close(code=UNAUTHENTICATED)
            return
        self.scope["user"] = user
        self.scope.pop("session", None)  # the ticket lets in, not a cookie the browser happened to send
        configuration = await database_sync_to_async(_configuration)(user)
        writer_ = self.scope.get("extensions", {}).get(FRAMES_EXTENSION, {}).get("writer")
        self.session = Session(user=user, operator=is_operator(user), owner=self.channel_name, send=self._send_frame,
                               writer=writer_, **configuration)
        await self.channel_layer.group_add(person_group(user.pk), self.channel_name)
        await self.channel_layer.group_add(FRONTDOOR_GROUP, self.channel_name)
        if self.session.operator:
            await self.channel_layer.group_add(LOCK_GROUP, self.channel_name)
        await self.accept()
        await self.session.start()
        await self._audit("frontdoor.connect", "connected")

    async def disconnect(self, code: int) -> None:
        if self.session is None:
            return
        await self.session.close()
        user = self.scope["user"]
        await self.channel_layer.group_discard(person_group(user.pk), self.channel_name)
        await self.channel_layer.group_discard(FRONTDOOR_GROUP, self.channel_name)
        await self.channel_layer.group_discard(LOCK_GROUP, self.channel_name)
        await self._audit("frontdoor.disconnect", f"disconnected (code {code})")

    async def receive(self, text_data: str | None = None, bytes_data: bytes | None = None) -> None:
        if self.session is not None:
            await self.session.handle(text_data if text_data is not None else bytes_data or b"")

    async def _send_frame(self, frame: str | bytes) -> None:
        await self.base_send({"type": "websocket.send", "bytes": frame} if isinstance(frame, bytes)
                             else {"type": "websocket.send", "text": frame})

    async def access_changed(self, event: dict[str, Any]) -> None:
        """The person's access, or what the admin lets tools do, changed: close if they may no
        longer be here, else go on under what is set now."""
        session = self.session
        if session is None:
            return
        if await close_if_revoked(self, event, operator=session.operator, end=session.close):
            return
        await session.configure(**await database_sync_to_async(_configuration)(self.scope["user"]))

    async def teleop_lock(self, event: LockEvent) -> None:
        if self.session is not None:
            await self.session.driver.on_lock_event(event)

    async def _audit(self, action: str, outcome: str) -> None:
        agent = next((v.decode("latin1")[:200] for k, v in self.scope.get("headers", ()) if k == b"user-agent"), "")
        await writer.record(user=self.scope["user"], source="frontdoor", action=action, params={"agent": agent},
                            ok=True, outcome=outcome, address=client_address.get())
