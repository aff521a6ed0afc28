"""The robot link's state, which each of its concerns (``status``, ``subscriptions``, ``serving``,
and the start and stop in ``connection``) builds on, in that order."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING, Any

import roslibpy

from robot import interface as ri
from robot.link.guard import CmdVelGuard
from robot.link.nav2 import Ros2Goals
from robot.link.rosclient import Publishers
from robot.live.fanout import Coalescer
from robot.live.state import StateStore
from robot.supervisor import Tasks

if TYPE_CHECKING:
    from robot.link.lease import Lease

# Between two reconnects asked for (the pages' button, the API): more often only flaps the link,
# and a flapping link cannot carry an E-STOP.
RECONNECT_INTERVAL_S = 5.0
# (topic name, type, message, receive time) for every message on every subscribed topic.
Listener = Callable[[str, str, dict[str, Any], float], None]


class LinkCore:
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
        self.url = url
        self.store = store
        self.layer = layer
        self.topics = list(topics if topics is not None else ri.monitored_topics())
        self.max_backoff_s = max_backoff_s
        self.service_timeout_s = service_timeout_s
        # Scaled mode: the Redis lease this link holds; it publishes only while the lease is still its own.
        self.lease = lease
        # Subscriptions the robot refused since the last (re)connect: topic -> rosbridge's reason.
        # roslibpy sends every subscription again on each reconnect; a refusal then is reported again.
        self.failed_subscriptions: dict[str, str] = {}
        self.listeners: list[Listener] = []
        self.connected = False
        # Which ROS the robot runs: forced by ROBOT_ROS, else found out on each connect (robot.link.dialect).
        self.ros_version = ri.ros_version()
        self.nav2 = Ros2Goals(url, lambda: self.ros, service_timeout_s)
        self.since = time.time()
        self.attempts = 0
        self.ros: roslibpy.Ros | None = None
        self.loop: asyncio.AbstractEventLoop | None = None
        self._loop_thread: int | None = None
        self._subscriptions: dict[str, roslibpy.Topic] = {}
        self._was_ready = False  # a connection was ready before (the next one subscribes again)
        # Who holds each upstream subscription (the registry, the recorder, watching pages, ...):
        # the subscription goes when its last holder lets go.
        self._holders: dict[str, set[str]] = {}
        self._publishers = Publishers()
        self._tasks: list[asyncio.Task] = []
        self._coalescer: Coalescer | None = None
        self._stopped = False
        self._serving: asyncio.Future | None = None
        self._inflight = Tasks()
        self._guard_settings = guard_settings or {"rate_hz": 10.0, "hold_s": 1.0, "deadman_s": 0.35}
        self.guard: CmdVelGuard | None = None
        self.request_queue = request_queue  # requests arrive on this queue (robot.live.queues)
        self.command_path = True  # until a ping over the request channel goes unanswered
        # Liveness (robot.link.liveness): when the robot last said anything (a message, a rosapi answer),
        # and whether that was recent enough to call it responding.
        self.heard_at = time.time()
        self.responding = True
        self.connecting_until = 0.0  # epoch time: until then, a link not yet connected is still connecting
        self._latch_msg: dict[str, Any] = {}
        # The last E-STOP this link took (epoch, who): written to the shared store if the store missed it.
        self._pressed_at = 0.0
        self._pressed_by = ""
        self._in_order = asyncio.Lock()  # publishes one at a time through the fencing check
        self._asked_reconnect_at = -RECONNECT_INTERVAL_S  # monotonic

    @property
    def stopped(self) -> bool:
        return self._stopped

    def last_press(self, now: float) -> tuple[str, float]:
        """Who pressed the E-STOP and when, as this link knows it: its own last press, else the stored latch."""
        by = str(self._latch_msg.get("by") or self._pressed_by or "")
        return by, float(self._pressed_at or self._latch_msg.get("at") or now)

    def keep(self, task: asyncio.Task) -> asyncio.Task:
        """A feature's long-running task that ends with this link (cancelled at its stop)."""
        self._tasks.append(task)
        return task

    def _spawn(self, coro: Any) -> None:
        self._inflight.start(coro)

    def _threadsafe(self, fn: Callable[..., Any], *args: Any) -> None:
        loop = self.loop
        if loop is not None and not loop.is_closed():
            loop.call_soon_threadsafe(fn, *args)
