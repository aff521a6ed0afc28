"""One page's audio socket: listening to the robot's microphone and push-to-talk.

client → server (text): {"type": "listen", "on": bool}
    | {"type": "talk", "on": true, "format": "S16LE", "rate": 16000, "channels": 1} | {"type": "talk", "on": false}
client → server (binary): one chunk of talk audio, 20-100 ms of the declared format
server → client (text): {"type": "hello", "can_listen", "can_talk", "talker", "you"}
    | {"type": "format", channels, sample_rate, sample_format, coding_format, robot_coding_format, assumed}
      (on listen, and again if the robot declares a new format: always S16LE "wave", whatever
      the robot's microphone sends)
    | {"type": "listening", "on"} | {"type": "talking", "on", "reason"}
    | {"type": "talker", "holder", "you", "reason"} (to everyone) | {"type": "error", "message", "code"}
    | {"type": "error", "code": "mic", "message"} (the link could not decode the microphone)
server → client (binary): one microphone chunk as PCM in the ``format`` frame's terms

Raw PCM from the robot is relayed as it came; mp3 is decoded to PCM once, in the link
(``robot.audio.mic`` says why the server decodes rather than the browser).

Operators and admins may listen and talk; viewers see who talks and are refused the rest.
Nothing heard or said is stored: the audit trail keeps who listened or talked, when, how long.
"""

from __future__ import annotations

import asyncio
import base64
import logging
import time
from collections.abc import Awaitable, Callable
from datetime import UTC, datetime
from typing import Any

from channels.db import database_sync_to_async
from django.conf import settings

from robot.audio.mic import Unplayable, playback_format
from robot.audio.pcm import Pacer, chunk_problem, format_problem
from robot.audio.talk import TalkEvent, announce_talker, get_talk_lock, talk_view
from robot.commands.audit import audit_record
from robot.commands.pipeline import Busy, InvalidCommand, arun_command
from robot.link.bus import RobotError, apublish, arequest
from robot.link.holders import RENEW_S
from robot.live.locks import HeldLock, Holder
from robot.live.state import get_store
from robot.supervisor import Tasks

log = logging.getLogger(__name__)

SendJSON = Callable[[dict[str, Any]], Awaitable[None]]
SendBytes = Callable[[bytes], Awaitable[None]]
Membership = Callable[[bool], Awaitable[None]]  # join (True) or leave (False) the microphone group
REFRESH_EVERY_S = 0.25
# The page starts sending once it hears the talk began (a round trip): its first chunk may take longer.
FIRST_CHUNK_S = 1.0


def _iso(t: float) -> str:
    return datetime.fromtimestamp(t, UTC).isoformat(timespec="milliseconds")


class AudioSession:
    def __init__(self, *, user: Any, owner: str, address: str, allowed: bool, send_json: SendJSON,
                 send_bytes: SendBytes, mic_group: Membership, lock: HeldLock | None = None) -> None:
        self.user = user
        self.me = Holder(owner=owner, username=user.get_username())
        self.address = address
        self.allowed = allowed
        self.send_json = send_json
        self.send_bytes = send_bytes
        self.mic_group = mic_group
        self.lock = lock or get_talk_lock()
        self.listening_since: float | None = None
        self.talk_since: float | None = None
        self.last_chunk = 0.0
        self.refreshed = 0.0
        self.pacer = Pacer()
        self.told_idle = False
        self._tasks = Tasks()
        self._renewing: asyncio.Task | None = None

    # --- lifecycle ---------------------------------------------------------------------

    async def start(self) -> None:
        holder = await self.lock.holder()
        await self.send_json({"type": "hello", "can_listen": self.allowed, "can_talk": self.allowed,
                              "talker": holder.username if holder else None, "you": holder == self.me})

    async def close(self) -> None:
        if self.talk_since is not None:
            await self._end_talk("disconnect")
        if self.listening_since is not None:
            await self._stop_listening("disconnect")
        self._tasks.cancel()

    # --- text messages -----------------------------------------------------------------

    async def handle(self, content: Any) -> None:
        kind = content.get("type") if isinstance(content, dict) else None
        try:
            if kind == "listen":
                await (self._listen() if content.get("on") else self._stop_listening("stop"))
            elif kind == "talk":
                await (self._talk(content) if content.get("on") else self._end_talk("stop"))
            else:
                raise InvalidCommand(f"Unknown message type {kind!r}")
        except RobotError as exc:
            await self.error(exc.message, exc.code)

    async def error(self, message: str, code: str) -> None:
        await self.send_json({"type": "error", "message": message, "code": code})

    # --- listening ---------------------------------------------------------------------

    async def _listen(self) -> None:
        if self.listening_since is not None:
            return

        fmt: dict[str, Any] = {}

        async def run() -> str:
            info = (await get_store().aget_many(["audio_info"])).get("audio_info")
            try:
                fmt.update(playback_format(info["msg"] if info else None), assumed=info is None)
            except Unplayable as exc:
                raise InvalidCommand(str(exc)) from None
            await arequest("audio_listen", listener=self.me.owner, on=True)
            return "listening"

        await arun_command(user=self.user, source="websocket", action="audio.listen.start",
                           params={"address": self.address}, run=run)
        self.listening_since = time.time()
        await self.mic_group(True)
        await self.send_json({"type": "format", **fmt})
        await self.send_json({"type": "listening", "on": True})
        self._renewing = self._tasks.start(self._renew())

    async def _renew(self) -> None:
        while True:
            await asyncio.sleep(RENEW_S)
            if self.listening_since is None:
                return
            try:
                await arequest("audio_listen", listener=self.me.owner, on=True)
            except RobotError as exc:
                log.warning("could not renew a listening lease: %s", exc.message)

    async def _stop_listening(self, reason: str) -> None:
        since, self.listening_since = self.listening_since, None
        if since is None:
            return
        renewing, self._renewing = self._renewing, None
        if renewing is not None:  # ended before the lease is given back: no renewal may follow it
            renewing.cancel()
            await asyncio.wait({renewing}, timeout=1)
        await self.mic_group(False)
        try:
            await arequest("audio_listen", listener=self.me.owner, on=False)
        except RobotError as exc:  # the lease expires by itself
            log.warning("could not give back a listening lease: %s", exc.message)
        until = time.time()
        await database_sync_to_async(audit_record)(
            user=self.user, source="websocket", action="audio.listen", ok=True,
            params={"from": _iso(since), "until": _iso(until), "duration_s": round(until - since, 2),
                    "address": self.address, "reason": reason},
            outcome=f"listened for {until - since:.1f} s",
        )
        if reason != "disconnect":
            await self.send_json({"type": "listening", "on": False})

    async def on_mic(self, event: dict[str, Any]) -> None:
        """What the microphone group hears (``robot.audio.link``), passed on while listening."""
        if self.listening_since is None:
            return
        if event["type"] == "audio.mic":
            await self.send_bytes(event["data"])
        elif event["type"] == "audio.format":
            await self.send_json({"type": "format", **event["format"]})
        else:
            await self.error(str(event["message"]), "mic")

    # --- talking -----------------------------------------------------------------------

    async def _talk(self, content: dict[str, Any]) -> None:
        if self.talk_since is not None:
            return

        async def run() -> str:
            problem = format_problem(content)
            if problem:
                raise InvalidCommand(problem)
            current = await self.lock.acquire(self.me)
            if current != self.me:
                raise Busy(f"{current.username} is talking.")
            try:
                await arequest("audio_declare")
            except RobotError:
                await self.lock.release(self.me)
                raise
            return "talk started"

        await arun_command(user=self.user, source="websocket", action="audio.talk.start",
                           params={"address": self.address}, run=run)
        self.talk_since = self.last_chunk = self.refreshed = time.monotonic()
        self.pacer = Pacer()
        self.told_idle = False
        await self.send_json({"type": "talking", "on": True, "reason": "start"})
        await announce_talker(self.me, "start")
        self._tasks.start(self._watch_quiet())

    async def _watch_quiet(self) -> None:
        quiet = settings.AUDIO_TALK_QUIET_S
        while self.talk_since is not None:
            wait = quiet if self.pacer.audio_s else max(quiet, FIRST_CHUNK_S)
            left = self.last_chunk + wait - time.monotonic()
            if left <= 0:
                await self._end_talk("quiet")
                return
            await asyncio.sleep(min(left, 0.05))

    async def chunk(self, data: bytes) -> None:
        if self.talk_since is None:
            if not self.told_idle:  # chunks already in flight when a talk ends are expected
                self.told_idle = True
                await self.error("Not talking: hold Talk first; this audio was dropped.", "not_talking")
            return
        problem = chunk_problem(data) or self.pacer.admit(data)
        if problem:
            await self.error(f"Audio chunk refused: {problem}", "invalid")
            return
        now = time.monotonic()
        self.last_chunk = now
        if now - self.refreshed >= REFRESH_EVERY_S:
            self.refreshed = now
            if not await self.lock.refresh(self.me):
                await self._end_talk("lost")
                return
        try:
            await apublish("speaker", {"data": base64.b64encode(data).decode()})
        except RobotError as exc:
            await self.error(f"Audio did not reach the robot: {exc.message}", exc.code)
            await self._end_talk(exc.code)

    async def _end_talk(self, reason: str, *, release: bool = True) -> None:
        since, self.talk_since = self.talk_since, None
        if since is None:
            return
        duration = time.monotonic() - since
        if release and await self.lock.release(self.me):
            await announce_talker(None, reason)
        await database_sync_to_async(audit_record)(
            user=self.user, source="websocket", action="audio.talk", ok=True,
            params={"duration_s": round(duration, 2), "audio_s": round(self.pacer.audio_s, 2),
                    "reason": reason, "address": self.address},
            outcome=f"talked for {duration:.1f} s ({reason})",
        )
        if reason != "disconnect":
            await self.send_json({"type": "talking", "on": False, "reason": reason})

    async def on_talk_event(self, event: TalkEvent) -> None:
        if event["reason"] == "estop" and self.talk_since is not None:
            await self._end_talk("estop", release=False)  # the E-STOP already freed the lock
        await self.send_json(talk_view(event["holder"], event["owner"], self.me, event["reason"]))

