"""The process's live fan-out hub: every watching websocket of this web process, fed once per update.

Topic updates do not travel through per-socket channel-layer groups (that costs clients x topics
work per message). Instead each web process keeps one hub on its event loop:

- a socket registers the keys it watches;
- an update arrives already serialised (once per process) and is offered to each watching
  socket's slot: latest value wins for coalesced keys, every message is kept (bounded) for
  event-like keys;
- paced per UI tick (on average at most one frame per tick, short bursts allowed), every socket
  with something new gets ONE frame carrying every changed key, written with one cheap send; a
  socket whose previous write has not finished is skipped until a later flush, so a slow browser
  gets the newest value later and never stalls the others or the link.

Under Daphne a socket comes with a ``FrameWriter`` (server.patches.direct_frames): sockets with the
same pending updates share one encoded websocket frame, written with one ``send`` each, in the
flush itself; "still writing" means the kernel has not taken the previous frame yet. Elsewhere
(the test communicator) frames go through the consumer's ASGI send.

Embedded, the robot link feeds the hub directly; scaled, each web process holds one Redis
subscription that feeds it (robot.live.feed).
"""

from __future__ import annotations

import asyncio
import functools
import itertools
import json
import logging
import threading
import time
from collections.abc import Awaitable, Callable, Iterable
from typing import Any, Protocol

from cyborg_site.bucket import Bucket
from robot.live.frames import batch_frame, status_text, ws_text_frame
from robot.supervisor import spawn

log = logging.getLogger(__name__)

# Writes one websocket text frame (the ASGI send of the socket's consumer, wrapped).
Send = Callable[[str], Awaitable[None]]


# The ASGI scope extension under which a websocket offers its FrameWriter (server.patches.direct_frames).
FRAMES_EXTENSION = "cyborg.frames"


class FrameWriter(Protocol):
    """Writes pre-encoded websocket frames to one connection (server.patches.direct_frames)."""

    def write(self, frame: bytes) -> bool: ...
    def backlog(self) -> int: ...


# Frames are paced by a token bucket: on average at most one frame per socket per TICK_S, with
# bursts of up to BURST frames at once, so an update rarely waits for the pace (a 10 Hz pose right
# after a 1 Hz reading goes out at once instead of a tick later). With a token in hand the flush
# waits no timer, only FLUSH_TURNS loop turns: time for the loop to poll its sockets once more and
# pass what it read through the link (read, the link's coalescer task, the hub). The robot
# publishes pose and odometry together as two rosbridge frames a few tens of microseconds apart;
# flushed on the pose alone, the odometry would wait for the writes to every socket, and take a
# second frame (bench/live_fanout.py). Fed from Redis,
# updates the link published together arrive as separate messages a Redis round trip or two
# apart: that hub waits REDIS_GATHER_S so they still share a frame.
TICK_S = 0.02
BURST = 3.0
FLUSH_TURNS = 3
REDIS_GATHER_S = 0.002
# Per socket: event-like messages kept while it is slow (older ones are dropped and counted).
MAX_PENDING = 300
_seq = itertools.count()


class Socket:
    """One websocket's watched keys and pending updates (pre-serialised JSON fragments)."""

    __slots__ = ("dropped", "keys", "pending", "send", "sending", "status", "tracking", "writer")
    framed = True  # written by the hub's flush (False: a socket that writes its updates itself)

    def __init__(self, send: Send, writer: FrameWriter | None = None) -> None:
        self.send = send
        self.writer = writer
        self.keys: set[str] = set()
        self.pending: dict[Any, str] = {}  # key (latest wins) or (key, seq) (every message) -> fragment
        self.status: str | None = None  # the newest status frame not yet sent
        self.sending = False
        self.dropped = 0
        # While the first snapshot is read: receive time of the live updates already offered per key.
        self.tracking: dict[str, list[float]] | None = None

    def offer(self, key: str, fragment: str, t: float, every: bool) -> None:
        pending = self.pending
        if every:
            if len(pending) >= MAX_PENDING:
                del pending[next(iter(pending))]
                self.dropped += 1
            pending[(key, next(_seq))] = fragment
        else:
            pending.pop(key, None)  # re-insert: the frame lists keys roughly in arrival order
            pending[key] = fragment
        if self.tracking is not None:
            self.tracking.setdefault(key, []).append(t)

    def take(self) -> list[str | tuple[str, ...]]:
        """What to write next, and no longer pending: the status frame, then the updates' fragments."""
        parts: list[str | tuple[str, ...]] = []
        if self.status is not None:
            parts.append(self.status)
            self.status = None
        if self.pending:
            parts.append(tuple(self.pending.values()))
            self.pending.clear()
        return parts


class Hub:
    def __init__(self, loop: asyncio.AbstractEventLoop, *, tick_s: float = TICK_S, gather_s: float = 0.0) -> None:
        self.loop = loop
        self.tick_s = tick_s
        self.gather_s = gather_s  # how long a fresh update waits for others (fed from Redis: REDIS_GATHER_S)
        self.sockets: set[Socket] = set()
        self._watchers: dict[str, set[Socket]] = {}
        self._dirty: set[Socket] = set()
        self._flush_at: float | None = None
        self._pace = Bucket(1.0 / tick_s, BURST)
        self._flushing: asyncio.Task | None = None
        self._thread = threading.get_ident()
        self._link_status = status_text(None)
        self.services_down: dict[str, str] = {}

    # --- sockets ---------------------------------------------------------------------

    def attach(self, send: Send, writer: FrameWriter | None = None) -> Socket:
        return self.add(Socket(send, writer))

    def add(self, socket: Socket) -> Socket:
        self.sockets.add(socket)
        return socket

    def detach(self, socket: Socket) -> None:
        self.sockets.discard(socket)
        self._dirty.discard(socket)
        self.unwatch(socket, list(socket.keys))
        socket.pending.clear()

    def watch(self, socket: Socket, keys: Iterable[str]) -> None:
        for key in keys:
            if key not in socket.keys:
                socket.keys.add(key)
                self._watchers.setdefault(key, set()).add(socket)

    def unwatch(self, socket: Socket, keys: Iterable[str]) -> None:
        """Stop sending ``keys`` to ``socket`` (updates already pending for them are dropped)."""
        for key in keys:
            if key not in socket.keys:
                continue
            socket.keys.discard(key)
            socket.pending.pop(key, None)
            watchers = self._watchers.get(key)
            if watchers is not None:
                watchers.discard(socket)
                if not watchers:
                    del self._watchers[key]

    def watched_keys(self) -> list[str]:
        return list(self._watchers)

    # --- updates ---------------------------------------------------------------------

    def publish(self, key: str, fragment: str, t: float, *, every: bool = False) -> None:
        """Offer one serialised update (``{"key":…,"msg":…,"t":…}``) to every socket watching ``key``."""
        if threading.get_ident() != self._thread:
            self.loop.call_soon_threadsafe(functools.partial(self.publish, key, fragment, t, every=every))
            return
        watchers = self._watchers.get(key)
        if not watchers:
            return
        framed = False
        for socket in watchers:
            socket.offer(key, fragment, t, every)
            if socket.framed:
                self._dirty.add(socket)
                framed = True
        if framed:
            self._schedule()

    def publish_status(self, frame: str) -> None:
        """A link status frame for every socket (latest wins)."""
        if threading.get_ident() != self._thread:
            self.loop.call_soon_threadsafe(self.publish_status, frame)
            return
        self._link_status = frame
        self._send_status()

    def set_services(self, down: dict[str, str]) -> None:
        """The backing services this process cannot reach (name -> what that means), added to every
        status frame: the link's status travels through Redis, this is what the process sees itself."""
        if down != self.services_down:
            self.services_down = down
            self._send_status()

    def status_frame(self, link_status: str | None = None) -> str:
        """The status frame as sockets get it: the link's, with this process's view of its services."""
        frame = link_status if link_status is not None else self._link_status
        if not self.services_down:
            return frame
        return json.dumps({**json.loads(frame), "services_down": self.services_down}, separators=(",", ":"))

    def _send_status(self) -> None:
        frame = self.status_frame()
        for socket in self.sockets:
            if socket.framed:
                socket.status = frame
                self._dirty.add(socket)
        self._schedule()

    def offer(self, socket: Socket, key: str, fragment: str, t: float, *, every: bool = False) -> None:
        """One socket only (its first snapshot)."""
        if socket in self.sockets:
            socket.offer(key, fragment, t, every)
            self._dirty.add(socket)
            self._schedule()

    # --- writing ---------------------------------------------------------------------

    def _schedule(self, at_least: float | None = None) -> None:
        if self._flush_at is not None:
            return
        now = time.monotonic()
        wait = max(self.gather_s if at_least is None else at_least, self._pace.wait(now))
        self._flush_at = now + wait
        if wait > 0:
            self.loop.call_at(self.loop.time() + wait, self._flush)
        else:
            self.loop.call_soon(self._flush_after, FLUSH_TURNS - 1)

    def _flush_after(self, turns: int) -> None:
        if turns:
            self.loop.call_soon(self._flush_after, turns - 1)
        else:
            self._flush()

    def _flush(self) -> None:
        self._flush_at = None
        if self._flushing is not None and not self._flushing.done():
            return  # the previous writes are still running; they schedule the next flush as they end
        dirty = self._dirty
        later: list[Socket] = []
        via_send: list[Socket] = []
        encoded: dict[Any, bytes] = {}  # one encoded frame per distinct content, shared by every socket
        written = 0
        for socket in dirty:
            writer = socket.writer
            if writer is None:
                if socket.sending:
                    later.append(socket)
                else:
                    via_send.append(socket)
                continue
            backlog = writer.backlog()
            if backlog > 0:
                later.append(socket)  # the kernel has not taken its last frame: newest values next tick
                continue
            if backlog < 0:
                continue  # closing; the consumer detaches it
            for part in socket.take():
                frame = encoded.get(part)
                if frame is None:
                    frame = encoded[part] = ws_text_frame(_text(part))
                writer.write(frame)
            written += 1
        dirty.clear()
        if written or via_send:
            self._pace.take()  # polling slow sockets alone costs no frame
        if later:
            dirty.update(later)
            self._schedule(at_least=0.0 if written or via_send else self.tick_s)  # stuck sockets: poll per tick
        if via_send:
            self._flushing = spawn(self._write(via_send), loop=self.loop)

    async def _write(self, sockets: list[Socket]) -> None:
        for socket in sockets:
            frames = [_text(part) for part in socket.take()]
            socket.sending = True
            try:
                for frame in frames:
                    await socket.send(frame)
            except Exception:
                log.debug("live socket write failed", exc_info=True)
            finally:
                socket.sending = False
        if self._dirty:
            self._schedule()


def _text(part: str | tuple[str, ...]) -> str:
    """A frame's text: the status frame as it is, pending fragments batched."""
    return part if isinstance(part, str) else batch_frame(part)


_hubs: dict[asyncio.AbstractEventLoop, Hub] = {}


def get_hub() -> Hub:
    """The hub of the running event loop (one per web process; tests get one per loop)."""
    loop = asyncio.get_running_loop()
    hub = _hubs.get(loop)
    if hub is None:
        for dead in [lp for lp in _hubs if lp.is_closed()]:
            del _hubs[dead]
        hub = _hubs[loop] = Hub(loop)
    return hub

