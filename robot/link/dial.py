"""The link's connection to rosbridge: dialling it (roslibpy redials by itself with a backoff), whether
it is up and the robot answers (``robot.link.liveness`` keeps ``heard_at`` and ``responding``), and
dialling again at once when asked or when rosbridge's port listens again.

roslibpy's Twisted transport delivers callbacks on the reactor thread. Inside Daphne that is the
asyncio loop's own thread; in ``manage.py robotlink`` and in tests the reactor is a thread of its own
and every callback hops onto the asyncio loop with ``threadsafe``. Nothing in a callback blocks.
"""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from collections.abc import Callable
from typing import Any
from urllib.parse import urlsplit

import roslibpy

from robot import interface as ri
from robot.link.rosclient import LinkRos, close_quietly

log = logging.getLogger(__name__)

# While the robot is away, how often to look whether rosbridge's port is listening again.
PORT_WATCH_S = 0.2
# After starting (a standby taking over), requests wait this long for the first connection instead of
# being refused as "robot offline": a rolling restart of the links refuses nothing.
FIRST_CONNECT_S = 3.0


class Dial:
    def __init__(self, url: str, *, max_backoff_s: float) -> None:
        self.url = url
        self.max_backoff_s = max_backoff_s
        self.ros: roslibpy.Ros | None = None
        self.loop: asyncio.AbstractEventLoop | None = None
        self.loop_thread: int | None = None
        self.stopped = False
        self.connected = False
        self.since = time.time()
        self.attempts = 0
        # Liveness: when the robot last said anything (a message, a rosapi answer), and whether that
        # was recent enough to call it responding.
        self.heard_at = time.time()
        self.responding = True
        self.connecting_until = 0.0  # epoch time: until then, a link not yet connected is still connecting
        # Which ROS the robot runs: forced by ROBOT_ROS, else found out on each connect (robot.link.dialect).
        self.ros_version = ri.ros_version()

    def threadsafe(self, fn: Callable[..., Any], *args: Any) -> None:
        loop = self.loop
        if loop is not None and not loop.is_closed():
            loop.call_soon_threadsafe(fn, *args)

    def open(self, *, array_topics: frozenset[str], on_reactor_ready: Callable[[Any], None],
             on_ready: Callable[[float], None], on_close: Callable[[], None]) -> None:
        """Dial (and later redial by itself); ``on_reactor_ready(proto)`` runs on the reactor's thread
        before anything else goes out on a new connection, the others on the loop."""
        from twisted.internet import reactor

        self.loop = asyncio.get_running_loop()
        self.loop_thread = threading.get_ident()
        self.connecting_until = time.time() + FIRST_CONNECT_S
        self.ros = LinkRos(self.url, array_topics=array_topics)
        self.ros.factory.maxDelay = self.max_backoff_s
        self.ros.factory.initialDelay = 0.5
        # The time is taken here, in the reactor's thread, so every message of the new connection
        # (stamped there too) is later than `since`: what came before a robot restart is older.
        self.ros.on("ready", on_reactor_ready)
        self.ros.on("ready", lambda *_: self.threadsafe(on_ready, time.time()))
        self.ros.on("close", lambda *_: self.threadsafe(on_close))
        if (proto := getattr(self.ros.factory, "_proto", None)) is not None:
            # With the reactor already running (a second link in a process, tests) the
            # connection can open before the "ready" handlers above were registered.
            on_reactor_ready(proto)
            self.threadsafe(on_ready, time.time())
        if not reactor.running:
            self.ros.factory.manager.run()  # a reactor thread of our own (not inside Daphne)

    def ready(self, at: float) -> bool:
        """A connection is up; False once stopped."""
        if self.stopped:
            return False
        self.connected, self.since, self.attempts = True, at, 0
        self.heard_at, self.responding = at, True
        log.info("robot link connected to %s", self.url)
        return True

    def closed(self) -> bool:
        """The connection is gone (or an attempt failed); True when it was up."""
        if self.stopped:
            return False
        was = self.connected
        if was:
            log.warning("robot link lost %s; reconnecting", self.url)
            self.since = time.time()
        self.connected = False
        self.attempts += 1
        return was

    def count_attempts(self) -> None:
        # Failed connection attempts emit no "close"; count them from the factory.
        if self.ros is not None and not self.connected:
            self.attempts = max(self.attempts, getattr(self.ros.factory, "retries", 0))

    async def watch_port(self) -> None:
        """While disconnected, try again the moment rosbridge's port listens (not after the backoff)."""
        parts = urlsplit(self.url)
        host, port = parts.hostname or "127.0.0.1", parts.port or (443 if parts.scheme == "wss" else 80)
        while not self.stopped:
            await asyncio.sleep(PORT_WATCH_S)
            if self.connected or self.ros is None:
                continue
            try:
                _, writer = await asyncio.wait_for(asyncio.open_connection(host, port), PORT_WATCH_S * 2)
            except (OSError, TimeoutError):
                continue
            writer.close()
            if not self.connected:
                log.info("rosbridge's port %s:%d is listening again; reconnecting now", host, port)
                self.reconnect(keep_open=True)
                await asyncio.sleep(1)  # give the handshake time before looking again

    def reconnect(self, *, keep_open: bool = False) -> None:
        """Try now instead of waiting out the backoff (the page's reconnect button).

        With ``keep_open`` a connection that is open (or opening) stays as it is.
        """
        from twisted.internet import reactor

        ros = self.ros
        if ros is None:
            return

        def _now() -> None:
            factory = ros.factory
            proto = getattr(factory, "_proto", None)
            connecting = factory.connector is not None and factory.connector.state != "disconnected"
            if keep_open and (proto is not None or connecting):
                return
            # Cancel the backoff's pending retry before resetDelay(), which forgets it without
            # cancelling: it would fire while this connection is up ("can't connect in this state").
            call = getattr(factory, "_callID", None)
            if call is not None and call.active():
                call.cancel()
            factory.resetDelay()
            if proto is not None:
                proto.dropConnection(abort=True)  # the factory reconnects at once
            elif factory.connector is not None and factory.connector.state == "disconnected":
                factory.connector.connect()

        reactor.callFromThread(_now)

    async def close(self) -> None:
        """Hang up for good, within a few seconds whatever the network does."""
        self.stopped = True
        if self.ros is not None:
            ros, self.ros = self.ros, None
            ros.factory.stopTrying()
            if ros.is_connected:
                try:
                    await asyncio.wait_for(asyncio.get_running_loop().run_in_executor(None, close_quietly, ros), 3)
                except TimeoutError:
                    log.warning("the rosbridge connection did not close in time; going on")
        self.connected = False
