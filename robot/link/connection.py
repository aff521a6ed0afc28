"""The robot link: the one rosbridge connection per robot.

roslibpy's Twisted transport delivers callbacks on the reactor thread. Inside Daphne that
is the asyncio loop's own thread, and a topic message is handled right there, in the read that
brought it; in ``manage.py robotlink`` and in tests the reactor is a thread of its own and every
callback hops onto the asyncio loop with ``call_soon_threadsafe``. Nothing in a callback blocks.
"""

from __future__ import annotations

import asyncio
import logging
import re
import threading
import time
import weakref
from collections.abc import Awaitable, Callable, Iterable
from typing import TYPE_CHECKING, Any, cast
from urllib.parse import urlsplit

import roslibpy

from robot import interface as ri
from robot.link import redisqueue
from robot.link.guard import CmdVelGuard
from robot.link.rosclient import LinkRos, call_service, close_quietly
from robot.live import trace
from robot.live.announce import aannounce, aannounce_status, server_update
from robot.live.fanout import Coalescer
from robot.live.groups import (
    LATCH_KEY,
    LINK_CHANNEL,
    REPLY_LIST_PREFIX,
    LinkReply,
    LinkRequest,
    LinkStatus,
    TopicUpdate,
)
from robot.live.latchstate import Latch
from robot.live.state import LINK_HEARTBEAT_S, StateStore
from robot.supervisor import cancel_and_wait, failing, supervise

if TYPE_CHECKING:
    from robot.link.lease import Lease

log = logging.getLogger(__name__)


# While the robot is away, how often to look whether rosbridge's port is listening again.
PORT_WATCH_S = 0.2
LATCH_SETTLE_S = 3.0  # a stop's store write normally lands within milliseconds
# After starting (a standby taking over), requests wait this long for the first connection instead of
# being refused as "robot offline": a rolling restart of the links refuses nothing.
FIRST_CONNECT_S = 3.0
# Between two reconnects asked for (the pages' button, the API): more often only flaps the link,
# and a flapping link cannot carry an E-STOP.
RECONNECT_INTERVAL_S = 5.0
REPLY_MARGIN_S = 0.3
_NO_ROBOT_NEEDED = frozenset({"ping", "reconnect", "estop_release"})  # answered at once
# ROS 1 rosbridge answers a subscription it cannot make (a message package the robot lacks) only on
# /rosout, as an error from its own node naming the request id roslibpy gave it.
_ROSBRIDGE_NODE = "/rosbridge_websocket"
_FAILED_SUBSCRIBE = re.compile(r"\[id: subscribe:(?P<topic>/[^\]]*?):\d+\] subscribe: (?P<error>.*)", re.S)

# (topic name, type, message, receive time) for every message on every subscribed topic.
Listener = Callable[[str, str, dict[str, Any], float], None]
# Per-key handlers replace the generic store/fan-out path (e.g. the map renderer).
Handler = Callable[[ri.Topic, dict[str, Any], float], Awaitable[None] | None]

# Extra link operations other modules add (e.g. robot/link/audio.py): (link, request) -> reply.
Operation = Callable[["RobotLink", LinkRequest], Awaitable[LinkReply]]

_handlers: dict[str, Handler] = {}
_operations: dict[str, Operation] = {}
# Called with the link as it starts, before its first message (modules that listen to every topic).
_start_hooks: list[Callable[[RobotLink], None]] = []
_array_keys: set[str] = set()
# Holders of upstream subscriptions: the registry's monitored topics, and a plain subscribe
# (kept until unsubscribed, e.g. the navigation's own topics).
REGISTRY_HOLDER = "registry"
PINNED_HOLDER = "pinned"


def register_handler(key: str, handler: Handler, *, arrays: bool = False) -> None:
    """Route ``key``'s messages to ``handler`` instead of the store and browsers (apps call this in ready()).

    With ``arrays`` a large message's integer ``data`` array (a map's cells) arrives as a numpy array.
    """
    _handlers[key] = handler
    if arrays:
        _array_keys.add(key)
    else:
        _array_keys.discard(key)


def register_operation(op: str, operation: Operation) -> None:
    _operations[op] = operation


def register_start(hook: Callable[[RobotLink], None]) -> None:
    if hook not in _start_hooks:
        _start_hooks.append(hook)


def array_topics() -> frozenset[str]:
    return frozenset(ri.topic(key).name for key in _array_keys)


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
        request_queue: str = "",
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
        self.since = time.time()
        self.attempts = 0
        self.ros: roslibpy.Ros | None = None
        self.loop: asyncio.AbstractEventLoop | None = None
        self._loop_thread: int | None = None
        self._subscriptions: dict[str, roslibpy.Topic] = {}
        # Who holds each upstream subscription (the registry, the recorder, watching pages, ...):
        # the subscription goes when its last holder lets go.
        self._holders: dict[str, set[str]] = {}
        self._publishers: dict[str, roslibpy.Topic] = {}
        self._tasks: list[asyncio.Task] = []
        self._coalescer: Coalescer | None = None
        self._stopped = False
        self._serving: asyncio.Future | None = None
        self._inflight: set[asyncio.Future] = set()
        self._guard_settings = guard_settings or {"rate_hz": 10.0, "hold_s": 1.0, "deadman_s": 0.35}
        self.guard: CmdVelGuard | None = None
        self.request_queue = request_queue  # scaled: requests arrive on this Redis list (robot.link.redisqueue)
        self.command_path = True  # until a ping over the request channel goes unanswered
        self.connecting_until = 0.0  # epoch time: until then, a link not yet connected is still connecting
        self._latch_msg: dict[str, Any] = {}
        # The last E-STOP this link took (epoch, who): written to the shared store if the store missed it.
        self._pressed_at = 0.0
        self._pressed_by = ""
        self._in_order = asyncio.Lock()  # publishes one at a time through the fencing check
        self._asked_reconnect_at = -RECONNECT_INTERVAL_S  # monotonic

    # --- lifecycle -------------------------------------------------------------------

    async def start(self, *, serve_requests: bool = True) -> None:
        from twisted.internet import reactor

        self.loop = asyncio.get_running_loop()
        self._loop_thread = threading.get_ident()
        self.connecting_until = time.time() + FIRST_CONNECT_S
        self._coalescer = Coalescer(self._send_update, loop=self.loop)
        self.guard = CmdVelGuard(self._publish_zero, loop=self.loop, **self._guard_settings)
        await self._sync_latch()
        for hook in _start_hooks:
            hook(self)
        self.ros = LinkRos(self.url, array_topics=array_topics())  # connects (and later reconnects) by itself
        self.ros.factory.maxDelay = self.max_backoff_s
        self.ros.factory.initialDelay = 0.5
        # The time is taken here, in the reactor's thread, so every message of the new connection
        # (stamped there too) is later than `since`: what came before a robot restart is older.
        self.ros.on("ready", lambda *_: self._threadsafe(self._on_ready, time.time()))
        self.ros.on("close", lambda *_: self._threadsafe(self._on_close))
        if getattr(self.ros.factory, "_proto", None) is not None:
            # With the reactor already running (a second link in a process, tests) the
            # connection can open before the "ready" handler above was registered.
            self._threadsafe(self._on_ready, time.time())
        if not reactor.running:
            self.ros.factory.manager.run()  # a reactor thread of our own (not inside Daphne)
        for t in self.topics:
            self.subscribe(t.name, t.type, holder=REGISTRY_HOLDER)
        self._tasks.append(supervise("link.heartbeat", self._heartbeat))
        self._tasks.append(supervise("link.port-watch", self._watch_port))
        if serve_requests:
            self._serving = supervise("link.requests", self._serve)
            self._tasks.append(self._serving)
        await self.publish_status()

    async def stop(self) -> None:
        """Stop within a few seconds whatever the network does (every wait is bounded)."""
        self._stopped = True
        if self._serving is not None:
            try:
                # Wake the loop's pop rather than cancel it: cancelling a Redis layer receive mid-BZPOPMIN
                # can hang its connection, and a cancelled list pop could lose the request it took.
                if self.request_queue:
                    await self._wake_list_pop()
                else:
                    await asyncio.wait_for(self.layer.send(LINK_CHANNEL, {"type": "link.stop"}), 1)
            except Exception:
                log.warning("could not tell the robot link's request loop to stop", exc_info=True)
            # The loop ends at the stop message, or after its current pop (a Redis list pop returns
            # within a second) if another link on the list took the message: a request it took is
            # served. (asyncio.wait: however the loop ended, cancelled or failed, the stop goes on.)
            _, running = await asyncio.wait({self._serving}, timeout=redisqueue.POP_TIMEOUT_S + 1)
            if running:
                log.warning("robot link request loop did not stop in time")
        if self._inflight:
            await asyncio.wait(set(self._inflight), timeout=2)  # answer what it took while the robot is there
        if self._coalescer is not None:
            self._coalescer.close()  # ends its sender
            self._tasks.append(self._coalescer._task)
        await cancel_and_wait([*self._tasks, *self._inflight], 2)
        self._tasks.clear()
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

    async def _wake_list_pop(self) -> None:
        try:
            await asyncio.wait_for(redisqueue.push(self.request_queue, {"type": "link.stop"}), 1)
        except Exception:
            log.debug("could not wake the request loop; it stops after its current pop", exc_info=True)

    def _spawn(self, coro: Any) -> None:
        task = asyncio.ensure_future(coro)
        self._inflight.add(task)
        task.add_done_callback(self._inflight.discard)

    def _threadsafe(self, fn: Callable[..., Any], *args: Any) -> None:
        loop = self.loop
        if loop is not None and not loop.is_closed():
            loop.call_soon_threadsafe(fn, *args)

    def _received(self, name: str, msg_type: str, msg: dict[str, Any]) -> None:
        """A topic message, on the reactor thread: handled at once when that is the loop's own
        thread (Daphne), not a self-pipe wake-up and a loop turn later."""
        t = time.time()
        if threading.get_ident() != self._loop_thread:
            self._threadsafe(self._on_message, name, msg_type, msg, t)
            return
        try:
            self._on_message(name, msg_type, msg, t)
        except Exception:  # never into roslibpy's read: the connection must survive a bad message
            log.exception("handling a message on %s failed", name)

    # --- subscriptions ---------------------------------------------------------------

    def subscribe(self, name: str, msg_type: str, *, holder: str = PINNED_HOLDER) -> None:
        """Hold the upstream subscription to ``name`` for ``holder``: one rosbridge subscription per
        topic however many holders; later calls for the same topic only add the holder."""
        if self.ros is None:
            return
        self._holders.setdefault(name, set()).add(holder)
        if name in self._subscriptions:
            return
        topic = roslibpy.Topic(self.ros, name, msg_type)
        topic.subscribe(lambda msg, _n=name, _t=msg_type: self._received(_n, _t, msg))
        self._subscriptions[name] = topic

    def unsubscribe(self, name: str, *, holder: str = PINNED_HOLDER) -> None:
        """Let go of ``holder``'s hold on ``name``; the upstream subscription goes with the last holder
        (the registry's monitored topics are always held)."""
        holders = self._holders.get(name)
        if holders is not None:
            holders.discard(holder)
            if holders:
                return
            del self._holders[name]
        topic = self._subscriptions.pop(name, None)
        if topic is not None:
            topic.unsubscribe()

    def holders(self, name: str) -> frozenset[str]:
        return frozenset(self._holders.get(name, ()))

    @property
    def subscribed(self) -> set[str]:
        return set(self._subscriptions)

    def _on_message(self, name: str, msg_type: str, msg: dict[str, Any], t: float) -> None:
        if self._stopped:
            return
        if name == ri.topic("rosout").name and msg.get("name") == _ROSBRIDGE_NODE:
            self._note_refusal(str(msg.get("msg", "")))
        for listener in self.listeners:
            try:
                listener(name, msg_type, msg, t)
            except Exception:
                log.exception("link listener failed for %s", name)
        topic = ri.topic_by_name(name)
        if topic is None:
            return
        handler = _handlers.get(topic.key)
        if handler is not None:
            result = handler(topic, msg, t)
            if asyncio.iscoroutine(result):
                self._spawn(result)
            return
        if trace.enabled:
            trace.begin(topic.key, t, msg)
        update: TopicUpdate = {
            "type": "robot.update", "key": topic.key, "topic": name, "msg_type": msg_type, "msg": msg, "t": t,
        }
        assert self._coalescer is not None
        self._coalescer.offer(topic.key, topic.ui_rate_hz, update)

    async def _send_update(self, update: TopicUpdate) -> None:
        key = update["key"]
        if trace.enabled:
            trace.mark(update["t"], "drain")
        await aannounce(key, dict(update), recent=ri.topic(key).recent, store=self.store)

    # --- connection status -----------------------------------------------------------

    def _note_refusal(self, text: str) -> None:
        refused = _FAILED_SUBSCRIBE.search(text)
        if refused is None or refused["topic"] not in self._subscriptions:
            return
        first = refused["topic"] not in self.failed_subscriptions
        self.failed_subscriptions[refused["topic"]] = refused["error"].strip()
        if first:
            log.error("the robot refused the subscription to %s (tried again on every reconnect): %s",
                      refused["topic"], refused["error"].strip())
            self._spawn(self.publish_status())

    def _on_ready(self, at: float) -> None:
        if self._stopped:
            return
        self.failed_subscriptions.clear()  # roslibpy subscribes again now; refusals come back on /rosout
        self.connected, self.since, self.attempts = True, at, 0
        log.info("robot link connected to %s", self.url)
        self._spawn(self.publish_status())

    def _on_close(self) -> None:
        if self._stopped:
            return
        if self.connected:
            log.warning("robot link lost %s; reconnecting", self.url)
            self.since = time.time()
        self.connected = False
        self.attempts += 1
        self._spawn(self.publish_status())

    def status(self) -> LinkStatus:
        return {
            "type": "robot.status", "connected": self.connected, "url": self.url,
            "since": self.since, "attempts": self.attempts, "link_alive": time.time(),
            "command_path": self.command_path, "failing_tasks": failing(),
            "holder": self.lease.holder if self.lease is not None else None,
            "failed_subscriptions": dict(self.failed_subscriptions),
            "connecting_until": self.connecting_until,
        }

    async def set_command_path(self, ok: bool) -> None:
        """What the last ping over the request channel found, published every time: a store
        that came back empty from an outage has the link's status again within a second."""
        if ok != self.command_path:
            (log.info if ok else log.error)("command path %s", "answers again" if ok else "DOWN: a ping got no answer")
            self.command_path = ok
        await self.publish_status()

    async def publish_status(self) -> None:
        status = self.status()
        try:
            await aannounce_status(dict(status), store=self.store)
        except Exception:
            log.exception("could not publish link status")

    async def _heartbeat(self) -> None:
        while not self._stopped:
            await asyncio.sleep(LINK_HEARTBEAT_S)
            # Failed connection attempts emit no "close"; count them from the factory.
            if self.ros is not None and not self.connected:
                self.attempts = max(self.attempts, getattr(self.ros.factory, "retries", 0))
            await self._sync_latch()
            await self.publish_status()

    async def _sync_latch(self) -> None:
        """Follow the shared latch; if the store lost it (Redis restarted empty) while this link
        holds a stop, write it back: a latch ends only by an operator's release."""
        try:
            entry = (await self.store.aget_many([LATCH_KEY])).get(LATCH_KEY)
            if self.guard is None:
                return
            if entry is not None:
                self._latch_msg = dict(entry.get("msg") or {})
            # A stop or release this link took moments ago may not be in the store yet: reading
            # the store then would undo it, or write back a latch without who and when.
            if not self.guard.settled(LATCH_SETTLE_S):
                return
            stored = Latch.from_msg(self._latch_msg if entry is not None else None)
            if self.guard.latched and self._pressed_at > max(stored.at, stored.released_at) and not stored.latched:
                log.warning("the shared store missed an E-STOP this link took: writing it")
                pressed = Latch(latched=True, by=self._pressed_by, at=self._pressed_at)
                await aannounce(LATCH_KEY, dict(server_update(LATCH_KEY, pressed.as_msg())), store=self.store)
            elif entry is not None:
                self.guard.sync(bool(self._latch_msg.get("latched")))
            elif self.guard.latched:
                log.warning("the shared store lost the E-STOP latch: writing it back")
                msg = self._latch_msg if self._latch_msg.get("latched") else {"latched": True}
                await aannounce(LATCH_KEY, dict(server_update(LATCH_KEY, msg)), store=self.store)
        except Exception:
            log.exception("could not read the E-STOP latch")

    async def _watch_port(self) -> None:
        """While disconnected, try again the moment rosbridge's port listens (not after the backoff)."""
        parts = urlsplit(self.url)
        host, port = parts.hostname or "127.0.0.1", parts.port or (443 if parts.scheme == "wss" else 80)
        while not self._stopped:
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
            factory.resetDelay()
            call = getattr(factory, "_callID", None)
            if call is not None and call.active():
                call.cancel()
                factory._callID = None
            if proto is not None:
                proto.dropConnection(abort=True)  # the factory reconnects at once
            elif factory.connector is not None and factory.connector.state == "disconnected":
                factory.connector.connect()

        reactor.callFromThread(_now)

    # --- requests from web processes and tasks ---------------------------------------

    async def _serve(self) -> None:
        while not self._stopped:
            if self.request_queue:
                request = await redisqueue.pop(self.request_queue)
                if request is None:
                    continue
            else:
                request = await self.layer.receive(LINK_CHANNEL)
            if request.get("type") == "link.stop":
                if self._stopped:
                    return
                continue  # a stale stop message from an earlier link
            self._spawn(self._handle(cast(LinkRequest, request)))

    async def answer(self, request: LinkRequest) -> LinkReply | None:
        """``execute`` for a request that came from another process; None if it came too late."""
        deadline = request.get("deadline", float("inf"))
        if deadline < time.time():
            log.warning("dropped a %s request that arrived after its deadline", request.get("op"))
            return None
        # A link just started (a standby taking over) serves requests queued meanwhile once connected,
        # or still says "offline" in time for the caller to hear it.
        while (not self.connected and request.get("op") not in _NO_ROBOT_NEEDED
               and time.time() < min(deadline - REPLY_MARGIN_S, self.connecting_until)):
            await asyncio.sleep(0.02)
        return await self.execute(request)

    async def _handle(self, request: LinkRequest) -> None:
        reply = await self.answer(request)
        if reply is None:
            return
        reply.update({"type": "link.reply", "request_id": request.get("request_id", "")})
        reply_to = request.get("reply_to") or ""
        if reply_to.startswith(REPLY_LIST_PREFIX):
            await redisqueue.push(reply_to.removeprefix(REPLY_LIST_PREFIX), dict(reply))
        elif reply_to:
            await self.layer.send(reply_to, reply)

    async def execute(self, request: LinkRequest) -> LinkReply:
        op = request.get("op")
        if op == "reconnect":
            wait = self._asked_reconnect_at + RECONNECT_INTERVAL_S - time.monotonic()
            if wait > 0:
                return {"ok": False, "error_code": "throttled",
                        "error": f"The robot link reconnected moments ago; try again in {max(1, round(wait))} s."}
            self._asked_reconnect_at = time.monotonic()
            self.reconnect()
            return {"ok": True}
        if op == "ping":
            return {"ok": True}
        if op in _operations:
            return await _operations[op](self, request)
        if op == "estop_release":
            if self.guard is not None:
                self.guard.release()
            return {"ok": True}
        if op == "estop" and self.guard is not None:
            self.guard.engage()  # latched even when the robot is offline
            self._pressed_at = max(self._pressed_at, float(request.get("at") or time.time()))
            self._pressed_by = str(request.get("by") or self._pressed_by)
        if not self.connected or self.ros is None or not self.ros.is_connected:
            return {"ok": False, "error_code": "offline", "error": f"Robot offline: no connection to {self.url}"}
        if op == "publish" and self.lease is not None and not request.get("emergency"):
            # One at a time through the fencing check's round trip to Redis, in the order they came:
            # a driver's last Twist must not overtake the zero sent after it.
            async with self._in_order:
                return await self._fenced(request)
        return await self._fenced(request)

    async def _fenced(self, request: LinkRequest) -> LinkReply:
        if self.lease is not None and not await self._fenced_ok(request):
            # The fencing check: another link may hold the lease now; never command the robot twice.
            return {"ok": False, "error_code": "offline",
                    "error": "This robot link lost its lease; the other one takes over"}
        op = request.get("op")
        if op == "estop":
            return {"ok": True}
        if op == "publish":
            refused = self._held_back(request, request["topic"], request["msg"])
            if refused:
                return refused
            self._publisher(request["topic"], request["msg_type"]).publish(roslibpy.Message(request["msg"]))
            return {"ok": True}
        if op == "call_service":
            return await self._call_service(request)
        return {"ok": False, "error_code": "invalid", "error": f"Unknown link operation {op!r}"}

    async def _fenced_ok(self, request: LinkRequest) -> bool:
        """The lease still ours: proved by its token in Redis, or, for what only stops the robot, not
        known to be lost (Redis out of reach: nobody else can hold it then)."""
        assert self.lease is not None
        if request.get("op") == "estop" or request.get("emergency"):
            return self.lease.may_stop
        return await self.lease.check()

    def _held_back(self, request: LinkRequest, name: str, msg: dict[str, Any]) -> LinkReply | None:
        """The last check before the robot: the latch, on every publish and service call."""
        if self.guard is None:
            return None
        refusal = self.guard.check_publish(name, msg, by_the_stop=bool(request.get("stopping")))
        return {"ok": False, "error_code": "estop", "error": refusal} if refusal else None

    def _publish_zero(self) -> None:
        if self.ros is None or not self.ros.is_connected:
            raise RuntimeError("robot offline")
        if self.lease is not None and not self.lease.may_stop:
            raise RuntimeError("this robot link no longer holds the lease")
        cmd_vel = ri.topic("cmd_vel")
        self._publisher(cmd_vel.name, cmd_vel.type).publish(roslibpy.Message(ri.ZERO_TWIST))

    def _publisher(self, name: str, msg_type: str) -> roslibpy.Topic:
        topic = self._publishers.get(name)
        if topic is None:
            topic = self._publishers[name] = roslibpy.Topic(self.ros, name, msg_type, queue_size=10)
        return topic

    async def call(self, service: ri.Service, args: dict[str, Any] | None = None, *,
                   timeout: float | None = None) -> LinkReply:
        """Call one of the robot's services from where the link runs (never blocks the loop)."""
        if not self.connected or self.ros is None:
            return {"ok": False, "error_code": "offline", "error": f"Robot offline: no connection to {self.url}"}
        request: LinkRequest = {"service": service.name, "service_type": service.type, "args": args or {}}
        if timeout is not None:
            request["timeout"] = timeout
        return await self._call_service(request)

    async def _call_service(self, request: LinkRequest) -> LinkReply:
        refused = self._held_back(request, request["service"], request.get("args") or {})
        if refused:
            return refused
        assert self.ros is not None
        timeout = float(request.get("timeout") or self.service_timeout_s)
        reply = await call_service(self.ros, request["service"], request["service_type"], request.get("args") or {},
                                   timeout)
        return cast(LinkReply, reply)


def one_per_link[T](make: Callable[[RobotLink], T]) -> Callable[[RobotLink], T]:
    """``make(link)`` once for each link, kept for as long as the link lives."""
    made: weakref.WeakKeyDictionary[RobotLink, T] = weakref.WeakKeyDictionary()

    def of(link: RobotLink) -> T:
        found = made.get(link)
        if found is None:
            found = made[link] = make(link)
        return found

    return of


# The link hosted by this process, if any (embedded default, robotlink command, tests).
current: RobotLink | None = None
