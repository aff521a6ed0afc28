"""The robot's microphone and speakers, where the link runs.

The link subscribes to the microphone once, while at least one page listens, whatever the
number of listeners or web processes: each listening page holds a lease (``audio_listen``)
that it renews; the subscription goes with the last lease (given back, or expired because
a web process died). Every chunk is decoded from base64 once and sent as bytes to the
listeners' group, where each page's socket forwards it as a binary frame.

Operator audio goes out with the link's ordinary ``publish``; ``audio_declare`` publishes
the speaker's format, latched, as the robot's audio player expects it before any chunk.
"""

from __future__ import annotations

import base64
import binascii
import logging
import time
import weakref
from typing import Any

import roslibpy

from robot import interface as ri
from robot.link.connection import RobotLink, register_handler, register_operation
from robot.live.groups import MIC_GROUP, LinkReply, LinkRequest, SharedMessage

log = logging.getLogger(__name__)

# A listener renews its lease every LISTEN_RENEW_S; one not renewed for LISTEN_LEASE_S is gone.
LISTEN_RENEW_S = 2.0
LISTEN_LEASE_S = 6.0


class Listeners:
    """The leases of one link; subscribed exactly while any lease is alive."""

    def __init__(self, link: RobotLink) -> None:
        self.link = link
        self.leases: dict[str, float] = {}  # listener id -> expiry (monotonic)
        self.topic = ri.topic("audio")

    def set(self, listener: str, on: bool) -> None:
        if on:
            self.leases[listener] = time.monotonic() + LISTEN_LEASE_S
        else:
            self.leases.pop(listener, None)
        self.sweep()

    def sweep(self) -> None:
        now = time.monotonic()
        for listener in [k for k, expiry in self.leases.items() if expiry <= now]:
            del self.leases[listener]
        if self.leases:
            self.link.subscribe(self.topic.name, self.topic.type)
        else:
            self.link.unsubscribe(self.topic.name)


_listeners: weakref.WeakKeyDictionary[RobotLink, Listeners] = weakref.WeakKeyDictionary()


def listeners_of(link: RobotLink) -> Listeners:
    found = _listeners.get(link)
    if found is None:
        found = _listeners[link] = Listeners(link)
    return found


def chunk_bytes(msg: dict[str, Any]) -> bytes:
    """AudioData ``data`` (uint8[]): base64 on the rosbridge wire, a list of ints from some bridges."""
    data = msg.get("data", "")
    if isinstance(data, str):
        return base64.b64decode(data, validate=True)
    return bytes(data)


async def _listen(link: RobotLink, request: LinkRequest) -> LinkReply:
    listeners_of(link).set(str(request["listener"]), bool(request.get("on")))
    return {"ok": True, "listeners": len(listeners_of(link).leases)}


async def _declare(link: RobotLink, request: LinkRequest) -> LinkReply:
    if not link.connected or link.ros is None:
        return {"ok": False, "error_code": "offline", "error": f"Robot offline: no connection to {link.url}"}
    info = ri.topic("speaker_info")
    topic = roslibpy.Topic(link.ros, info.name, info.type, latch=True)
    topic.publish(roslibpy.Message(ri.speaker_info()))
    return {"ok": True}


async def _on_mic(link_topic: ri.Topic, msg: dict[str, Any], t: float) -> None:
    from robot.link import connection

    link = connection.current
    if link is None:
        return
    listeners = listeners_of(link)
    listeners.sweep()
    if not listeners.leases:
        return
    try:
        data = chunk_bytes(msg)
    except (binascii.Error, ValueError, TypeError):
        log.warning("dropped a microphone chunk that is not base64 audio")
        return
    await link.layer.group_send(MIC_GROUP, SharedMessage(type="audio.mic", data=data, t=t))


def install() -> None:
    register_handler("audio", _on_mic)
    register_operation("audio_listen", _listen)
    register_operation("audio_declare", _declare)
