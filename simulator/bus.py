"""What a simulated ROS node sees of the simulator: the ROS graph, the clock and /rosout.

``SimRobot`` owns one ``Bus`` and hands it to every node's ``start``. A node never
touches the websocket or another node's topics directly: it publishes and
handles topics by their key in ``robot/interface.py``, answers services, asks the clock
to call it back, and logs to /rosout. That is all a new node needs (see README.md).
"""

from __future__ import annotations

import asyncio
import collections
import itertools
import logging
import math
import time
from collections.abc import Callable, Coroutine
from dataclasses import dataclass
from typing import Any, Protocol

from robot import interface as ri

from .messages import ROS1, Dialect


class Peer(Protocol):
    """A rosbridge client as the graph holds it (``protocol.Client``)."""

    id: int
    address: str
    connected_at: float

    def reply(self, frame: dict[str, Any]) -> None: ...

    def respond(self, mid: Any, service: str, values: Any, ok: bool) -> None: ...

    def release(self, what: Any) -> None: ...


class Delivery(Protocol):
    """One client's subscription as the graph feeds it (``protocol.Subscription``)."""

    raw: bool
    params: dict[Any, tuple[int, int]]

    def offer(self, frame: str | bytes) -> None: ...

    def update(self) -> None: ...

    def stop(self) -> None: ...


class ActionEndpoint:
    """A ROS 2 action server as rosbridge's action ops reach it (``actions.Ros2Action``)."""

    type: str

    def send_goal(self, client: Peer, op_id: Any, args: dict[str, Any]) -> None:
        raise NotImplementedError

    def cancel_goal(self, client: Peer, op_id: Any) -> None:
        raise NotImplementedError

log = logging.getLogger("simulator")

Handler = Callable[[dict[str, Any]], object]
ServiceHandler = Callable[[dict[str, Any]], dict[str, Any]]
RECEIVED_KEEP = 10_000
TickFn = Callable[[float, float], None]  # (monotonic now, dt seconds)
_LOG_LEVELS = {1: logging.DEBUG, 2: logging.INFO, 4: logging.WARNING, 8: logging.ERROR, 16: logging.CRITICAL}


class SimNode:
    """One simulated ROS node (or a few that always go together): every node subclasses it.

    ``names``: the ROS node names it plays (listed by /rosapi/nodes). ``publishes`` and
    ``answers``: the interface keys of the topics it publishes and the services it answers
    (tests hold them against ``robot/interface.py``). None of them unless a node gives them.
    ``start`` wires the node to the bus — handlers, services, periodic publishers, tasks — and
    may publish its first (latched) messages; it runs once, on the simulator's loop, before any
    client can connect. A node's own ``start`` calls this one first, which keeps the bus.
    ``stop`` ends whatever ``start`` began outside the bus (threads); tasks started with
    ``bus.spawn`` are cancelled by the simulator.
    """

    names: tuple[str, ...] = ()
    publishes: tuple[str, ...] = ()
    answers: tuple[str, ...] = ()
    bus: Bus

    def start(self, bus: Bus) -> None:
        self.bus = bus

    def stop(self) -> None:
        """Nothing runs outside the bus: the simulator cancels what ``bus.spawn`` started."""


class NoAnswer(Exception):
    """A service handler that never answers (its node died mid-call)."""


class ServiceError(Exception):
    """A service handler failed; the caller gets ``result: false`` with this text."""


@dataclass
class Received:
    t: float
    msg: dict[str, Any]


@dataclass
class Schedule:
    period: float
    fn: Callable[[], None]
    due: float = 0.0


class Clock:
    """The simulator's one tick: every node's per-tick step, then the periodic publishers that are due.

    Its time is the robot's world's: ``scale`` times as fast as the host's (motion, state timers,
    navigation, the commander's pauses, publishing rates), so a test that waits on the robot moving
    or a timer need not wait in real time. What stays in the host's time: the rosbridge protocol,
    message stamps, and the publishers' rates (a faster world is not a chattier one)."""

    def __init__(self, scale: float = 1.0) -> None:
        if not scale > 0:
            raise ValueError(f"time scale must be positive, not {scale}")
        self.scale = scale
        self._origin = time.monotonic()
        self.steps: list[TickFn] = []
        self.schedules: list[Schedule] = []

    def now(self) -> float:
        """The world's monotonic time, in seconds."""
        return self._origin + (time.monotonic() - self._origin) * self.scale

    async def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` of the world's time."""
        await asyncio.sleep(seconds / self.scale)

    def tick(self, now: float, dt: float, host_now: float) -> None:
        """``now`` and ``dt`` in the world's time; ``host_now`` (monotonic) paces the publishers."""
        for step in self.steps:
            step(now, dt)
        for s in self.schedules:
            if host_now >= s.due:
                s.due = s.due + s.period if host_now - s.due < s.period else host_now + s.period
                s.fn()


class Bus:
    """The ROS graph — topics, types, latched messages, services, ROS 2 action servers — as the
    nodes (by interface key) and the rosbridge clients (``protocol.Client``, by name) reach it."""

    def __init__(self, clock: Clock, dialect: Dialect = ROS1, goals_in_new_thread: bool = False,
                 services_in_new_thread: bool = False) -> None:
        self.clock = clock
        self.dialect = dialect
        self.encode = dialect.encode
        self.goals_in_new_thread = goals_in_new_thread
        self.services_in_new_thread = services_in_new_thread
        self.rosout_log: collections.deque[dict[str, Any]] = collections.deque(maxlen=200)
        self.tasks: list[asyncio.Task[Any]] = []
        self._warned: dict[str, float] = {}
        self.actions: dict[str, ActionEndpoint] = {}
        self.types: dict[str, str] = {}
        self.subs: dict[str, dict[int, Delivery]] = collections.defaultdict(dict)
        self.latched: dict[str, str] = {}
        self.lazy_latched: dict[str, Callable[[], dict[str, Any]]] = {}  # built for the first subscriber
        self.handlers: dict[str, list[Handler]] = collections.defaultdict(list)
        self.received_msgs: dict[str, collections.deque[Received]] = collections.defaultdict(
            lambda: collections.deque(maxlen=RECEIVED_KEEP))
        self.received_counts: collections.Counter[str] = collections.Counter()
        self.services: dict[str, tuple[str, ServiceHandler]] = {}
        self.client_services: dict[str, Peer] = {}  # service -> the client that advertised it
        self.clients: dict[int, Peer] = {}
        self.publishers: dict[str, set[int]] = collections.defaultdict(set)
        self.client_ids = itertools.count()
        self.call_ids = (f"service_request:{n}" for n in itertools.count())  # calls relayed to a client
        self.pending_calls: dict[str, tuple[Peer, Any, str]] = {}

    # --- topics ------------------------------------------------------------------------

    def topic(self, key: str) -> ri.Topic:
        """The interface topic ``key`` as the simulated robot's ROS names it."""
        return ri.topic(key, self.dialect.ros)

    def publish(self, key: str, msg: dict[str, Any]) -> None:
        """Publish on the interface topic ``key`` (latched if the interface says so)."""
        t = self.topic(key)
        self.publish_name(t.name, msg, latch=t.latched)

    def publish_name(self, name: str, msg: dict[str, Any], latch: bool = False) -> None:
        """Publish on a topic by its name (action servers, rosbridge's own, a client's publish)."""
        subs = self.subs.get(name)
        if not subs and not latch:
            return
        frame = self.encode({"op": "publish", "topic": name, "msg": msg})
        if latch:
            self.latched[name] = frame
        raw: bytes | None = None
        for sub in list(subs.values()) if subs else ():
            if sub.raw:
                raw = raw or self.dialect.raw_frame(name, self.types.get(name, ""), msg)
                sub.offer(raw)
            else:
                sub.offer(frame)

    def latched_frame(self, name: str) -> str | None:
        if name not in self.latched and name in self.lazy_latched:
            msg = self.lazy_latched.pop(name)()
            self.latched[name] = self.encode({"op": "publish", "topic": name, "msg": msg})
        return self.latched.get(name)

    def wants(self, key: str) -> bool:
        """Whether anyone subscribes to ``key``: costly messages are only built for a listener."""
        return bool(self.subs.get(self.topic(key).name))

    def subscription_count(self, name: str) -> int:
        return sum(len(s.params) for s in self.subs.get(name, {}).values())

    def announce(self, key: str, msg: dict[str, Any]) -> None:
        """A node publishing on a topic other nodes listen to: subscribers and in-process handlers get it."""
        name = self.topic(key).name
        self.publish_name(name, msg)
        for handler in self.handlers.get(name, ()):
            handler(msg)

    def deliver(self, name: str, msg: dict[str, Any], latch: bool) -> None:
        """A client's publish: record it, hand it to the robot's nodes and to every subscriber."""
        self.received_msgs[name].append(Received(time.time(), msg))
        self.received_counts[name] += 1
        self.publish_name(name, msg, latch=latch)
        for handler in self.handlers.get(name, ()):
            try:
                handler(msg)
            except Exception:  # a robot node's bug must not kill the client's session
                log.exception("handler for %s failed", name)

    def on(self, key: str, handler: Handler) -> None:
        """Call ``handler(msg)`` for every message a client (or ``announce``) publishes on ``key``."""
        self.on_name(self.topic(key).name, handler)

    def on_name(self, name: str, handler: Handler) -> None:
        self.handlers[name].append(handler)

    def declare(self, name: str, msg_type: str) -> None:
        """Make a topic the interface does not list known to rosapi and to clients."""
        self.types[name] = self.dialect.spell(msg_type)

    def latch_lazily(self, key: str, build: Callable[[], dict[str, Any]]) -> None:
        """A latched topic whose (large) message is only built when first needed."""
        self.lazy_latched[self.topic(key).name] = build

    # --- clients -------------------------------------------------------------------------

    def unsubscribe(self, client_id: int, name: str) -> None:
        """End a client's subscription to ``name`` (every id it subscribed with)."""
        sub = self.subs[name].pop(client_id, None)
        if sub:
            sub.stop()
        if not self.subs[name]:
            del self.subs[name]

    def disconnect(self, client: Peer) -> None:
        self.clients.pop(client.id, None)
        for name in list(self.subs):
            self.unsubscribe(client.id, name)
        for pubs in self.publishers.values():
            pubs.discard(client.id)
        self.client_services = {n: c for n, c in self.client_services.items() if c is not client}

    # --- services ------------------------------------------------------------------------

    def answer(self, key: str, handler: ServiceHandler) -> None:
        """Answer the interface service ``key``; raise ``ServiceError`` to fail a call."""
        s = ri.service(key, self.dialect.ros)
        self.answer_name(s.name, s.type, handler)

    def answer_name(self, name: str, srv_type: str, handler: ServiceHandler) -> None:
        self.services[name] = (self.dialect.spell(srv_type, "srv"), handler)

    # --- clock -----------------------------------------------------------------------------

    def every(self, period_s: float, fn: Callable[[], object], wanted: str | None = None) -> None:
        """Call ``fn()`` every ``period_s`` seconds of the simulator's tick; with ``wanted`` (a topic
        key), only while anyone subscribes to it, so a costly message is only built for a listener."""

        def call() -> None:
            if wanted is None or self.wants(wanted):
                fn()

        self.clock.schedules.append(Schedule(period_s, call))

    def each_tick(self, step: TickFn) -> None:
        """Call ``step(now, dt)`` on every tick, before the periodic publishers."""
        self.clock.steps.append(step)

    def spawn(self, coro: Coroutine[Any, Any, Any]) -> None:
        """Run a node's own loop on the simulator's event loop; the simulator cancels it on stop."""
        self.tasks.append(asyncio.get_running_loop().create_task(coro))

    # --- /rosout ---------------------------------------------------------------------------

    def rosout(self, level: int, node: str, text: str) -> None:
        """Log ``text`` from ``node``; ``level`` in ROS 1's scale (1 DEBUG .. 16 FATAL), whichever the ROS."""
        msg = self.dialect.log(level, node, text)
        self.rosout_log.append(msg)
        log.log(_LOG_LEVELS.get(level, logging.INFO), "%s: %s", node, text)
        self.publish("rosout", msg)

    def warn_once(self, key: str, node: str, text: str, every_s: float = 2.0, level: int = 4) -> None:
        """Log at most once every ``every_s`` seconds per ``key`` (a held joystick must not flood /rosout)."""
        now = time.monotonic()
        if now - self._warned.get(key, -math.inf) >= every_s:
            self._warned[key] = now
            self.rosout(level, node, text)
