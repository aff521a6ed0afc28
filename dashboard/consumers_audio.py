"""``/ws/audio/``: the robot's microphone out, push-to-talk in. The protocol lives in ``robot.audio.session``."""

from __future__ import annotations

import json
from typing import Any

from channels.db import database_sync_to_async
from channels.generic.websocket import AsyncWebsocketConsumer

from cyborg_site.roles import is_operator
from dashboard.consumers import UNAUTHENTICATED
from dashboard.fastdispatch import NoDatabaseHopMixin
from dashboard.revocation import close_if_revoked
from robot.audio.session import AudioSession
from robot.audio.talk import TalkEvent
from robot.live.groups import MIC_GROUP, TALK_GROUP, person_group


class AudioConsumer(NoDatabaseHopMixin, AsyncWebsocketConsumer):
    # Audio both ways must not queue behind database work; audits hop themselves.
    db_free_types = frozenset({"websocket.receive", "audio.mic", "audio.format", "audio.problem",
                               "audio.talk"})
    session: AudioSession | None = None

    async def connect(self) -> None:
        user = self.scope.get("user")
        if user is None or not user.is_authenticated:
            await self.close(code=UNAUTHENTICATED)
            return
        client = self.scope.get("client") or ("", 0)
        self.session = AudioSession(
            user=user, owner=self.channel_name, address=str(client[0]),
            allowed=await database_sync_to_async(is_operator)(user),
            send_json=lambda content: self.send(text_data=json.dumps(content)),
            send_bytes=lambda data: self.send(bytes_data=data), mic_group=self._mic_group,
        )
        await self.channel_layer.group_add(TALK_GROUP, self.channel_name)
        await self.channel_layer.group_add(person_group(user.pk), self.channel_name)
        await self.accept()
        await self.session.start()

    async def _mic_group(self, join: bool) -> None:
        if join:
            await self.channel_layer.group_add(MIC_GROUP, self.channel_name)
        else:
            await self.channel_layer.group_discard(MIC_GROUP, self.channel_name)

    async def disconnect(self, code: int) -> None:
        if self.session is None:
            return
        await self.session.close()
        await self.channel_layer.group_discard(TALK_GROUP, self.channel_name)
        await self.channel_layer.group_discard(person_group(self.scope["user"].pk), self.channel_name)

    async def receive(self, text_data: str | None = None, bytes_data: bytes | None = None) -> None:
        assert self.session is not None
        if bytes_data is not None:
            await self.session.chunk(bytes_data)
            return
        try:
            content: Any = json.loads(text_data or "")
        except ValueError:
            content = None
        await self.session.handle(content)

    async def access_changed(self, event: dict[str, Any]) -> None:
        """The person's access changed: stop listening and talking, and close, if they may no longer."""
        if self.session is not None:  # (its close: listening and talking end, audited)
            await close_if_revoked(self, event, operator=self.session.allowed, end=self.session.close)

    async def audio_mic(self, event: dict[str, Any]) -> None:
        if self.session is not None:
            await self.session.on_mic(event)

    audio_format = audio_problem = audio_mic

    async def audio_talk(self, event: TalkEvent) -> None:
        if self.session is not None:
            await self.session.on_talk_event(event)
