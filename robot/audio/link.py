"""The robot's microphone and speakers, where the link runs.

The link subscribes to the microphone once, while at least one page listens, whatever the
number of listeners or web processes: each listening page holds a lease (``audio_listen``)
that it renews; the subscription goes with the last lease (given back, or expired because
a web process died). Every chunk is decoded once, from base64 and, for an mp3 microphone, to
PCM (``robot.audio.mic`` says why there), and sent as bytes to the listeners' group, where
each page's socket forwards it as a binary frame. Audio that cannot be decoded is reported
to the listeners' group instead, at most every PROBLEM_EVERY_S; a new AudioInfo while pages
listen is announced to them as their new playback format.

Operator audio goes out with the link's ordinary ``publish``; ``audio_declare`` publishes
the speaker's format, latched, as the robot's audio player expects it before any chunk.
"""

from __future__ import annotations

import asyncio
import base64
import logging
import time
from typing import Any

import roslibpy

from robot import interface as ri
from robot.audio.mic import DecodeError, Mp3Decoder, PcmRelay, Unplayable, decoder_for, playback_format
from robot.link.connection import RobotLink, one_per_link
from robot.link.holders import Leases
from robot.link.serving import register_operation
from robot.link.subscriptions import register_handler
from robot.live.groups import MIC_GROUP, LinkReply, LinkRequest, SharedMessage
from robot.supervisor import Tasks, running

log = logging.getLogger(__name__)

PROBLEM_EVERY_S = 5.0
HOLDER = "audio"  # this module's hold on the microphone's upstream subscription


class Listeners:
    """The leases of one link; subscribed exactly while any lease is alive. Holds the
    microphone's declared format and the decoder of its current stream."""

    def __init__(self, link: RobotLink) -> None:
        self.link = link
        self.leases = Leases()  # the microphone's topic -> listener ids (robot.link.holders)
        self.topic = ri.topic("audio")
        self.info_topic = ri.topic("audio_info").name
        self.info: dict[str, Any] | None = None
        self.decoder: PcmRelay | Mp3Decoder | None = None
        self.reported = 0.0
        self._tasks = Tasks()
        # Each chunk's handler is a task of its own: sends wait their turn so that none
        # overtakes another (a group send to Redis awaits several times).
        self.sending = asyncio.Lock()
        link.listeners.append(self._on_message)

    def _on_message(self, name: str, msg_type: str, msg: dict[str, Any], t: float) -> None:
        if name == self.info_topic and dict(msg) != self.info:
            self.info, self.decoder = dict(msg), None
            if self.leases:  # pages already listening must play the new format
                self._tasks.start(self._announce_format())

    async def _announce_format(self) -> None:
        try:
            fmt: dict[str, Any] = {**playback_format(self.info), "assumed": False}
        except Unplayable as exc:
            await self.report(str(exc))
            return
        await self.link.layer.group_send(MIC_GROUP, {"type": "audio.format", "format": fmt})

    async def load_info(self) -> None:
        """The format latched before this link's listeners existed, from the store."""
        if self.info is None:
            entry = (await self.link.store.aget_many(["audio_info"])).get("audio_info")
            if entry and self.info is None:
                self.info, self.decoder = dict(entry["msg"]), None

    def decode(self, data: bytes) -> bytes:
        """PCM for the pages from one chunk (raises Unplayable or DecodeError). Synchronous: the
        chunks' handlers run as tasks, and a stream decoder must see them in order."""
        if self.decoder is None:
            self.decoder = decoder_for(self.info)
        return self.decoder.feed(data)

    async def report(self, problem: str) -> None:
        now = time.monotonic()
        if now - self.reported < PROBLEM_EVERY_S:
            return
        self.reported = now
        log.warning("robot microphone: %s", problem)
        await self.link.layer.group_send(MIC_GROUP, {"type": "audio.problem", "message": problem})

    def set(self, listener: str, on: bool) -> None:
        if on:
            self.leases.renew(self.topic.name, listener)
        else:
            self.leases.drop(self.topic.name, listener)
        self.sweep()

    def sweep(self) -> None:
        self.leases.expire()
        if self.leases:
            if self.topic.name not in self.link.subscriptions.subscribed:
                self.decoder = None  # a new stream
            self.link.subscriptions.subscribe(self.topic.name, self.topic.type, holder=HOLDER)
        else:
            self.link.subscriptions.unsubscribe(self.topic.name, holder=HOLDER)


listeners_of = one_per_link(Listeners)


def chunk_bytes(msg: dict[str, Any]) -> bytes:
    """AudioData ``data`` (uint8[]): base64 on the rosbridge wire, a list of ints from some bridges."""
    data = msg.get("data", "")
    if isinstance(data, str):
        return base64.b64decode(data, validate=True)
    return bytes(data)


async def _listen(link: RobotLink, request: LinkRequest) -> LinkReply:
    await listeners_of(link).load_info()
    listeners_of(link).set(str(request["listener"]), bool(request.get("on")))
    listeners = listeners_of(link)
    return {"ok": True, "listeners": len(listeners.leases.holders(listeners.topic.name))}


async def _declare(link: RobotLink, request: LinkRequest) -> LinkReply:
    if not link.connected or link.dial.ros is None:
        return {"ok": False, "error_code": "offline", "error": f"Robot offline: no connection to {link.dial.url}"}
    info = ri.topic("speaker_info")
    topic = roslibpy.Topic(link.dial.ros, info.name, info.type, latch=True)
    topic.publish(roslibpy.Message(ri.speaker_info()))
    return {"ok": True}


async def _on_mic(link_topic: ri.Topic, msg: dict[str, Any], t: float) -> None:
    link = running(RobotLink)
    if link is None:
        return
    listeners = listeners_of(link)
    listeners.sweep()
    if not listeners.leases:
        return
    # Decode before the first await, so chunks reach the decoder in the order they came.
    problem = pcm = None
    try:
        pcm = listeners.decode(chunk_bytes(msg))
    except Unplayable as exc:
        problem = str(exc)
    except DecodeError as exc:
        problem = f"The robot's microphone audio could not be decoded: {exc}"
    except (ValueError, TypeError) as exc:  # base64 or byte values
        problem = f"The robot's microphone sent a chunk that is not audio data ({exc}); it was dropped."
    async with listeners.sending:
        if problem:
            await listeners.report(problem)
        elif pcm:
            await link.layer.group_send(MIC_GROUP, SharedMessage(type="audio.mic", data=pcm, t=t))


def install() -> None:
    register_handler("audio", _on_mic)
    register_operation("audio_listen", _listen)
    register_operation("audio_declare", _declare)
