"""The robot link: the one rosbridge connection per robot, made of parts that each keep their own state
and meet only here: ``dial`` (the connection and its liveness, ``robot.link.dial``), ``subscriptions``,
``requests`` (``robot.link.serving``: the command bus, publishes and calls) and ``upkeep`` (its status),
with ``latch``, what it knows of the E-STOP (``robot.link.status``)."""

from __future__ import annotations

import asyncio
import logging
import weakref
from collections.abc import Callable, Iterable
from typing import Any

from robot import interface as ri
from robot.link.dial import Dial
from robot.link.guard import CmdVelGuard
from robot.link.lease import Lease
from robot.link.liveness import watch_liveness
from robot.link.nav2 import Ros2Goals
from robot.link.serving import Requests
from robot.link.status import LatchWatch, Upkeep
from robot.link.subscriptions import Listener, Subscriptions, array_topics
from robot.live import queues
from robot.live.state import StateStore
from robot.supervisor import Tasks, cancel_and_wait, supervise

log = logging.getLogger(__name__)

# Called with the link as it starts, before its first message (modules that listen to every topic).
_start_hooks: list[Callable[[RobotLink], object]] = []


def register_start(hook: Callable[[RobotLink], object]) -> None:
    if hook not in _start_hooks:
        _start_hooks.append(hook)


class RobotLink:
    def __init__(
        self,
        url: str,
        *,
        store: StateStore,
        layer: Any,
        topics: Iterable[ri.Topic] | None = None,
        max_backoff_s: float = 2.0,
        service_timeout_s: float = 5.0,
        guard_settings: dict[str, float] | None = None,
        request_queue: str,
        lease: Lease | None = None,
    ) -> None:
        self.store = store
        self.layer = layer
        self.dial = Dial(url, max_backoff_s=max_backoff_s)
        self.nav2 = Ros2Goals(url, lambda: self.dial.ros, service_timeout_s)
        self.latch = LatchWatch(store)
        self.subscriptions = Subscriptions(self.dial, store=store, topics=topics, nav2=self.nav2,
                                           service_timeout_s=service_timeout_s, spawn=self._spawn,
                                           changed=self._changed)
        self.requests = Requests(self.dial, self.latch, queue=request_queue, lease=lease, nav2=self.nav2,
                                 service_timeout_s=service_timeout_s, owner=self, spawn=self._spawn)
        self.upkeep = Upkeep(self.dial, self.subscriptions, self.latch, store=store,
                             holder=lambda: self.requests.lease.holder if self.requests.lease else None)
        self.listeners: list[Listener] = self.subscriptions.listeners
        self._guard_settings = guard_settings or {"rate_hz": 10.0, "hold_s": 1.0, "deadman_s": 0.35}
        self._tasks: list[asyncio.Task] = []
        self._inflight = Tasks()

    # --- what every feature shares, beside the parts ------------------------------------

    @property
    def connected(self) -> bool:
        return self.dial.connected

    def keep(self, task: asyncio.Task) -> asyncio.Task:
        """A feature's long-running task that ends with this link (cancelled at its stop)."""
        self._tasks.append(task)
        return task

    # --- start and stop ---------------------------------------------------------------

    def _spawn(self, coro: Any) -> None:
        self._inflight.start(coro)

    def _changed(self) -> None:
        self._spawn(self.upkeep.publish())

    def _ready(self, at: float) -> None:
        if self.dial.ready(at):
            self.subscriptions.ready()
            self._changed()

    def _closed(self) -> None:
        if self.dial.closed() and self.latch.guard is not None:
            self.latch.guard.lost()
        if not self.dial.stopped:
            self._changed()

    async def start(self, *, serve_requests: bool = True) -> None:
        self.latch.guard = CmdVelGuard(self.requests.publish_zero, loop=asyncio.get_running_loop(),
                                       **self._guard_settings)
        self.nav2.on_status = self.subscriptions.goal_status
        await self.latch.sync()
        self.dial.open(array_topics=array_topics(), on_reactor_ready=self.subscriptions.resubscribe,
                       on_ready=self._ready, on_close=self._closed)
        for hook in _start_hooks:
            hook(self)
        self.subscriptions.start()
        self._tasks += [supervise("link.heartbeat", self.upkeep.heartbeat),
                        supervise("link.port-watch", self.dial.watch_port),
                        supervise("link.liveness", lambda: watch_liveness(self.dial, self.upkeep.publish))]
        if serve_requests:
            self.requests.serving = supervise("link.requests", self.requests.serve)
            self._tasks.append(self.requests.serving)
        await self.upkeep.publish()

    async def stop(self) -> None:
        """Stop within a few seconds whatever the network does (every wait is bounded)."""
        self.dial.stopped = True
        if (serving := self.requests.serving) is not None:
            try:
                # Wake the loop's pop rather than cancel it: a cancelled list pop could lose the request it took.
                await asyncio.wait_for(queues.push(self.requests.request_queue, {"type": "link.stop"}), 1)
            except Exception:
                log.warning("could not tell the robot link's request loop to stop; it stops after its current pop",
                            exc_info=True)
            # The loop ends at the stop message, or after its current pop (a Redis list pop returns
            # within a second) if another link on the list took the message: a request it took is
            # served. (asyncio.wait: however the loop ended, cancelled or failed, the stop goes on.)
            _, running = await asyncio.wait({serving}, timeout=queues.POP_TIMEOUT_S + 1)
            if running:
                log.warning("robot link request loop did not stop in time")
        await self._inflight.wait(2)  # answer what it took while the robot is there
        if (sending := self.subscriptions.stop()) is not None:
            self._tasks.append(sending)
        await asyncio.gather(cancel_and_wait(self._tasks, 2), self._inflight.close(2))
        self._tasks.clear()
        self.nav2.close()
        if self.latch.guard is not None:
            self.latch.guard.stop()  # zero before the connection goes, if the robot may be moving
        await self.dial.close()


def one_per_link[T](make: Callable[[RobotLink], T]) -> Callable[[RobotLink], T]:
    """``make(link)`` once for each link, kept for as long as the link lives."""
    made: weakref.WeakKeyDictionary[RobotLink, T] = weakref.WeakKeyDictionary()

    def of(link: RobotLink) -> T:
        found = made.get(link)
        if found is None:
            found = made[link] = make(link)
        return found

    return of
