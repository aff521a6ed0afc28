"""The robot link: the one rosbridge connection per robot.

roslibpy's Twisted transport delivers callbacks on the reactor thread. Inside Daphne that
is the asyncio loop's own thread, and a topic message is handled right there, in the read that
brought it; in ``manage.py robotlink`` and in tests the reactor is a thread of its own and every
callback hops onto the asyncio loop with ``call_soon_threadsafe``. Nothing in a callback blocks.
"""

from __future__ import annotations

import asyncio
import logging
import threading
import time
import weakref
from collections.abc import Callable

from robot.link.guard import CmdVelGuard
from robot.link.liveness import watch_liveness
from robot.link.rosclient import LinkRos, close_quietly
from robot.link.serving import Serving
from robot.link.subscriptions import REGISTRY_HOLDER, array_topics
from robot.live import queues
from robot.live.fanout import Coalescer
from robot.supervisor import cancel_and_wait, supervise

log = logging.getLogger(__name__)


# After starting (a standby taking over), requests wait this long for the first connection instead of
# being refused as "robot offline": a rolling restart of the links refuses nothing.
FIRST_CONNECT_S = 3.0

# Called with the link as it starts, before its first message (modules that listen to every topic).
_start_hooks: list[Callable[[RobotLink], object]] = []


def register_start(hook: Callable[[RobotLink], object]) -> None:
    if hook not in _start_hooks:
        _start_hooks.append(hook)


class RobotLink(Serving):
    """One rosbridge connection: its start and stop here, on the layers of ``robot.link.core`` (its
    state), ``status`` (status and upkeep), ``subscriptions`` and ``serving`` (requests)."""

    async def start(self, *, serve_requests: bool = True) -> None:
        from twisted.internet import reactor

        self.loop = asyncio.get_running_loop()
        self._loop_thread = threading.get_ident()
        self.connecting_until = time.time() + FIRST_CONNECT_S
        self._coalescer = Coalescer(self._send_update, loop=self.loop)
        self.guard = CmdVelGuard(self._publish_zero, loop=self.loop, **self._guard_settings)
        self.nav2.on_status = self._goal_status
        await self._sync_latch()
        for hook in _start_hooks:
            hook(self)
        self.ros = LinkRos(self.url, array_topics=array_topics())  # connects (and later reconnects) by itself
        self.ros.factory.maxDelay = self.max_backoff_s
        self.ros.factory.initialDelay = 0.5
        # The time is taken here, in the reactor's thread, so every message of the new connection
        # (stamped there too) is later than `since`: what came before a robot restart is older.
        self.ros.on("ready", self._resubscribe)
        self.ros.on("ready", lambda *_: self._threadsafe(self._on_ready, time.time()))
        self.ros.on("close", lambda *_: self._threadsafe(self._on_close))
        if getattr(self.ros.factory, "_proto", None) is not None:
            # With the reactor already running (a second link in a process, tests) the
            # connection can open before the "ready" handler above was registered.
            self._was_ready = True
            self._threadsafe(self._on_ready, time.time())
        if not reactor.running:
            self.ros.factory.manager.run()  # a reactor thread of our own (not inside Daphne)
        for t in self.topics:
            self.subscribe(t.name, t.type, holder=REGISTRY_HOLDER)
        self._tasks.append(supervise("link.heartbeat", self._heartbeat))
        self._tasks.append(supervise("link.port-watch", self._watch_port))
        self._tasks.append(supervise("link.liveness", lambda: watch_liveness(self)))
        if serve_requests:
            self._serving = supervise("link.requests", self._serve)
            self._tasks.append(self._serving)
        await self.publish_status()

    async def stop(self) -> None:
        """Stop within a few seconds whatever the network does (every wait is bounded)."""
        self._stopped = True
        if self._serving is not None:
            try:
                # Wake the loop's pop rather than cancel it: a cancelled list pop could lose the request it took.
                await asyncio.wait_for(queues.push(self.request_queue, {"type": "link.stop"}), 1)
            except Exception:
                log.warning("could not tell the robot link's request loop to stop; it stops after its current pop",
                            exc_info=True)
            # The loop ends at the stop message, or after its current pop (a Redis list pop returns
            # within a second) if another link on the list took the message: a request it took is
            # served. (asyncio.wait: however the loop ended, cancelled or failed, the stop goes on.)
            _, running = await asyncio.wait({self._serving}, timeout=queues.POP_TIMEOUT_S + 1)
            if running:
                log.warning("robot link request loop did not stop in time")
        await self._inflight.wait(2)  # answer what it took while the robot is there
        if self._coalescer is not None:
            self._tasks.append(self._coalescer.close())
        await asyncio.gather(cancel_and_wait(self._tasks, 2), self._inflight.close(2))
        self._tasks.clear()
        self.nav2.close()
        if self.guard is not None:
            self.guard.stop()  # zero before the connection goes, if the robot may be moving
        if self.ros is not None:
            ros, self.ros = self.ros, None
            for topic in list(self._subscriptions.values()):
                topic.reconnect_on_close = False
            ros.factory.stopTrying()
            if ros.is_connected:
                try:
                    await asyncio.wait_for(asyncio.get_running_loop().run_in_executor(None, close_quietly, ros), 3)
                except TimeoutError:
                    log.warning("the rosbridge connection did not close in time; going on")
        self.connected = False


def one_per_link[T](make: Callable[[RobotLink], T]) -> Callable[[RobotLink], T]:
    """``make(link)`` once for each link, kept for as long as the link lives."""
    made: weakref.WeakKeyDictionary[RobotLink, T] = weakref.WeakKeyDictionary()

    def of(link: RobotLink) -> T:
        found = made.get(link)
        if found is None:
            found = made[link] = make(link)
        return found

    return of


