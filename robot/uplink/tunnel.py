"""The server's end of one uplink: channels opened over the agent's one connection."""

from __future__ import annotations

import asyncio
import itertools
import time
from typing import Any

from websockets.asyncio.server import ServerConnection

from robot.supervisor import Tasks
from uplink_agent import mux

OPEN_TIMEOUT_S = 5.0
# What one channel may hold unread before it is dropped (a reader that stopped reading).
CHANNEL_BACKLOG_BYTES = 32 * 1024 * 1024


class ChannelClosed(Exception):
    pass


class Channel:
    def __init__(self, tunnel: Tunnel, cid: int) -> None:
        self.tunnel = tunnel
        self.cid = cid
        self._frames: asyncio.Queue[tuple[int, bytes]] = asyncio.Queue()
        self._backlog = 0
        self.closed = False

    def feed(self, kind: int, payload: bytes) -> None:
        if self.closed:
            return
        if kind == mux.CLOSE:
            self.closed = True
        self._backlog += len(payload)
        if self._backlog > CHANNEL_BACKLOG_BYTES:
            self.closed = True
            kind, payload = mux.CLOSE, b"the reader fell too far behind"
            self.tunnel.forget(self, payload.decode())
        self._frames.put_nowait((kind, payload))

    async def next(self) -> tuple[int, bytes]:
        kind, payload = await self._frames.get()
        self._backlog -= len(payload)
        return kind, payload

    async def expect(self, kind: int, timeout: float = OPEN_TIMEOUT_S) -> bytes:
        """The payload of the next frame, which must be ``kind``; ChannelClosed otherwise."""
        try:
            got, payload = await asyncio.wait_for(self.next(), timeout)
        except TimeoutError:
            self.close("no answer from the robot in time")
            raise ChannelClosed("the robot's agent did not answer in time") from None
        if got != kind:
            self.close("")
            raise ChannelClosed(payload.decode(errors="replace") or "closed by the robot's agent")
        return payload

    async def send(self, payload: bytes) -> None:
        if self.closed:
            raise ChannelClosed("channel closed")
        await self.tunnel.connection.send(mux.encode_stamped(self.cid, time.monotonic(), payload))

    def close(self, reason: str = "") -> None:
        """Idempotent; tells the agent unless it closed the channel itself."""
        if not self.closed:
            self.closed = True
            self.tunnel.forget(self, reason)
        self.tunnel.channels.pop(self.cid, None)


class Tunnel:
    def __init__(self, connection: ServerConnection) -> None:
        self.connection = connection
        self.channels: dict[int, Channel] = {}
        self._ids = itertools.count(1)
        self.ended = False
        self._telling = Tasks()

    async def open(self, request: dict[str, Any]) -> Channel:
        if self.ended:
            raise ChannelClosed("the robot's uplink is closed")
        channel = Channel(self, next(self._ids))
        self.channels[channel.cid] = channel
        await self.connection.send(mux.encode_json(mux.OPEN, channel.cid, request))
        return channel

    def dispatch(self, message: bytes) -> None:
        kind, cid, payload = mux.decode(message)
        channel = self.channels.get(cid)
        if channel is not None:
            channel.feed(kind, payload)
            if kind == mux.CLOSE:
                self.channels.pop(cid, None)

    def forget(self, channel: Channel, reason: str) -> None:
        self.channels.pop(channel.cid, None)
        if not self.ended:
            self._telling.start(self._tell_closed(channel.cid, reason))

    async def _tell_closed(self, cid: int, reason: str) -> None:
        try:
            await self.connection.send(mux.encode(mux.CLOSE, cid, reason.encode()))
        except Exception:  # the uplink is going; its channels go with it
            pass

    def end(self) -> None:
        self.ended = True
        for channel in list(self.channels.values()):
            channel.feed(mux.CLOSE, b"the robot's uplink closed")
        self.channels.clear()
