"""The rosbridge v2 protocol as the ROS 1 rosbridge_server (and, with the ROS 2 dialect, the ROS 2 one) speaks it.

``Broker`` is the simulator's stand-in for the ROS graph (topics, latched messages,
services, ROS 2 action servers); ``Client`` is one websocket connection and its rosbridge
session. Frames a client gets wrong are logged (ERROR on /rosout from /rosbridge_websocket)
and dropped: neither server answers with ``status`` frames.

The ROS 2 server's launch defaults handle one op of a client at a time: a goal it sent, or a
call of a service another client serves, holds that client's later frames until it ends
(``goals_in_new_thread`` / ``services_in_new_thread`` lift that, as the launch arguments do).
"""

from __future__ import annotations

import asyncio
import collections
import itertools
import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from . import messages
from .messages import ROS1, Dialect

log = logging.getLogger("simulator.rosbridge")

RECEIVED_KEEP = 10_000

# level, text -> /rosout from /rosbridge_websocket
LogFn = Callable[[int, str], None]
ServiceHandler = Callable[[dict[str, Any]], dict[str, Any]]


class ProtocolError(Exception):
    """A frame rosbridge would refuse; logged and dropped."""


class NoAnswer(Exception):
    """A service handler that never answers (its node died mid-call)."""


class ServiceError(Exception):
    """A service handler failed; the caller gets ``result: false`` with this text."""


@dataclass
class Received:
    t: float
    msg: dict[str, Any]


@dataclass
class Subscription:
    """One client's server-side subscription to a topic, shared by its subscribe ids."""

    client: Client
    params: dict[Any, tuple[int, int]] = field(default_factory=dict)  # sid -> (throttle ms, queue length)
    throttle_s: float = 0.0
    last_sent: float = 0.0
    raw: bool = False  # compression cbor-raw: CBOR frames with the serialized message (Dialect.raw_frame)
    queue: collections.deque[str | bytes] | None = None
    wake: asyncio.Event | None = None
    pump: asyncio.Task[None] | None = None

    def update(self) -> None:
        self.throttle_s = min(p[0] for p in self.params.values()) / 1000.0
        queue_length = min(p[1] for p in self.params.values())
        if queue_length > 0:
            self.queue = collections.deque(self.queue or (), maxlen=queue_length)
            if self.pump is None:
                self.wake = asyncio.Event()
                self.pump = asyncio.get_running_loop().create_task(self._run_pump())
        else:
            self.stop()

    def offer(self, frame: str | bytes) -> None:
        if self.queue is not None and self.wake is not None:
            self.queue.append(frame)  # full deque drops the oldest, as rosbridge's queue does
            self.wake.set()
            return
        if self.throttle_s > 0.0:
            now = time.monotonic()
            if now - self.last_sent < self.throttle_s:
                return
            self.last_sent = now
        self.client.send(frame)

    async def _run_pump(self) -> None:
        assert self.wake is not None
        while True:
            await self.wake.wait()
            self.wake.clear()
            while self.queue:
                try:
                    await self.client.send_now(self.queue.popleft())
                except Exception:  # the connection went away; the session cleanup stops us
                    return
                if self.throttle_s > 0.0:
                    await asyncio.sleep(self.throttle_s)

    def stop(self) -> None:
        if self.pump is not None:
            self.pump.cancel()
        self.pump = self.queue = self.wake = None


class ActionEndpoint:
    """A ROS 2 action server as rosbridge's action ops reach it (``actions.Ros2Action``)."""

    type: str

    def send_goal(self, client: Client, op_id: Any, args: dict[str, Any]) -> None:
        raise NotImplementedError

    def cancel_goal(self, client: Client, op_id: Any) -> None:
        raise NotImplementedError


class Broker:
    """Topics, types, latched messages and services: the part of ROS the clients see."""

    def __init__(self, log_fn: LogFn, dialect: Dialect = ROS1, goals_in_new_thread: bool = False,
                 services_in_new_thread: bool = False) -> None:
        self.log = log_fn
        self.dialect = dialect
        self.encode = dialect.encode
        self.goals_in_new_thread = goals_in_new_thread
        self.services_in_new_thread = services_in_new_thread
        self.actions: dict[str, ActionEndpoint] = {}
        self.types: dict[str, str] = {}
        self.subs: dict[str, dict[int, Subscription]] = collections.defaultdict(dict)
        self.latched: dict[str, str] = {}
        self.lazy_latched: dict[str, Callable[[], dict[str, Any]]] = {}  # built for the first subscriber
        self.handlers: dict[str, list[Callable[[dict[str, Any]], object]]] = collections.defaultdict(list)
        self.received_msgs: dict[str, collections.deque[Received]] = collections.defaultdict(
            lambda: collections.deque(maxlen=RECEIVED_KEEP))
        self.received_counts: collections.Counter[str] = collections.Counter()
        self.services: dict[str, tuple[str, ServiceHandler]] = {}
        self.client_services: dict[str, Client] = {}  # service -> the client that advertised it
        self.clients: dict[int, Client] = {}
        self.publishers: dict[str, set[int]] = collections.defaultdict(set)
        self.client_ids = itertools.count()
        self.call_ids = (f"service_request:{n}" for n in itertools.count())  # calls relayed to a client
        self.pending_calls: dict[str, tuple[Client, Any, str]] = {}

    # --- robot side ------------------------------------------------------------------

    def wants(self, topic: str) -> bool:
        return bool(self.subs.get(topic))

    def publish(self, topic: str, msg: dict[str, Any], latch: bool = False) -> None:
        subs = self.subs.get(topic)
        if not subs and not latch:
            return
        frame = self.encode({"op": "publish", "topic": topic, "msg": msg})
        if latch:
            self.latched[topic] = frame
        raw: bytes | None = None
        for sub in list(subs.values()) if subs else ():
            if sub.raw:
                raw = raw or self.dialect.raw_frame(topic, self.types.get(topic, ""), msg)
                sub.offer(raw)
            else:
                sub.offer(frame)

    def latched_frame(self, topic: str) -> str | None:
        if topic not in self.latched and topic in self.lazy_latched:
            msg = self.lazy_latched.pop(topic)()
            self.latched[topic] = self.encode({"op": "publish", "topic": topic, "msg": msg})
        return self.latched.get(topic)

    # --- introspection ---------------------------------------------------------------

    def subscription_count(self, topic: str) -> int:
        return sum(len(s.params) for s in self.subs.get(topic, {}).values())

    # --- client side -----------------------------------------------------------------

    def unsubscribe(self, client_id: int, topic: str) -> None:
        """End a client's subscription to ``topic`` (every id it subscribed with)."""
        sub = self.subs[topic].pop(client_id, None)
        if sub:
            sub.stop()
        if not self.subs[topic]:
            del self.subs[topic]

    def disconnect(self, client: Client) -> None:
        self.clients.pop(client.id, None)
        for topic in list(self.subs):
            self.unsubscribe(client.id, topic)
        for pubs in self.publishers.values():
            pubs.discard(client.id)
        self.client_services = {n: c for n, c in self.client_services.items() if c is not client}

    def deliver(self, topic: str, msg: dict[str, Any], latch: bool) -> None:
        """A client's publish: record it, hand it to the robot's nodes and to every subscriber."""
        self.received_msgs[topic].append(Received(time.time(), msg))
        self.received_counts[topic] += 1
        self.publish(topic, msg, latch=latch)
        for handler in self.handlers.get(topic, ()):
            try:
                handler(msg)
            except Exception:  # a robot node's bug must not kill the client's session
                log.exception("handler for %s failed", topic)


def _check(frame: dict[str, Any], spec: list[tuple[bool, str, type]]) -> None:
    # rosbridge_library's Capability.basic_type_check (isinstance, so bool passes for int).
    for mandatory, name, expected in spec:
        if name not in frame:
            if mandatory:
                raise ProtocolError(f"Expected a {name} field but none was found.")
            continue
        if not isinstance(frame[name], expected):
            raise ProtocolError(
                f"Expected field {name} to have one of types ({expected.__name__}), but it has type "
                f"{type(frame[name]).__name__}"
            )


class Client:
    """One websocket client's rosbridge session."""

    OPS = (
        "advertise", "unadvertise", "publish", "subscribe", "unsubscribe", "call_service",
        "advertise_service", "unadvertise_service", "service_response", "fragment",
    )
    ACTION_OPS = ("send_action_goal", "cancel_action_goal")

    def __init__(self, broker: Broker, send: Callable[[str | bytes], Any], address: str = "") -> None:
        self.broker = broker
        self.id = next(broker.client_ids)
        self.address = address
        self.connected_at = time.time()
        self._send = send  # coroutine function: await send(text)
        self.outbox: asyncio.Queue[str | bytes] = asyncio.Queue()
        self.closed = False
        self.fragments: dict[Any, dict[int, str]] = {}
        self.ops = self.OPS + (self.ACTION_OPS if broker.dialect.ros2 else ())
        self.busy: set[Any] = set()  # what holds this client's frames (ROS 2 server, one op at a time)
        self.held: collections.deque[str | bytes] = collections.deque()

    # --- output ----------------------------------------------------------------------

    def send(self, frame: str | bytes) -> None:
        if not self.closed:
            self.outbox.put_nowait(frame)

    async def send_now(self, frame: str | bytes) -> None:
        if not self.closed:
            await self._send(frame)

    async def run_writer(self) -> None:
        while not self.closed:
            await self._send(await self.outbox.get())

    def reply(self, frame: dict[str, Any]) -> None:
        self.send(self.broker.encode(frame))

    def hold(self, what: Any) -> None:
        """Handle no more of this client's frames until ``release(what)``."""
        self.busy.add(what)

    def release(self, what: Any) -> None:
        self.busy.discard(what)
        while self.held and not self.busy:
            self.handle(self.held.popleft())

    def respond(self, mid: Any, service: str, values: Any, ok: bool) -> None:
        """A ``service_response`` frame, with the caller's id if it gave one."""
        self.reply({"op": "service_response", "service": service, "values": values, "result": ok,
                    **({} if mid is None else {"id": mid})})

    # --- input -----------------------------------------------------------------------

    def log(self, level: int, text: str, mid: Any = None) -> None:
        prefix = f"[Client {self.id}]" + (f" [id: {mid}]" if mid is not None else "")
        self.broker.log(level, f"{prefix} {text}")

    def handle(self, raw: str | bytes) -> None:
        if self.busy:
            self.held.append(raw)
            return
        try:
            frame = json.loads(raw)
        except ValueError:
            self.log(8, f"Unable to deserialize message from client: {str(raw)[:200]}")
            return
        if not isinstance(frame, dict) or "op" not in frame:
            self.log(
                8, "Received a message without an op.  All messages require 'op' field with value one of: "
                f"{list(self.ops)}.  Original message was: {str(raw)[:200]}",
            )
            return
        op, mid = frame["op"], frame.get("id")
        if op not in self.ops:
            self.log(8, f"Unknown operation: {op}.  Allowed operations: {list(self.ops)}", mid)
            return
        try:
            getattr(self, f"op_{op}")(frame, mid)
        except (ProtocolError, messages.ConversionError) as exc:
            self.log(8, f"{op}: {exc}", mid)
        except Exception as exc:  # e.g. an unhashable id: rosbridge logs and carries on too
            log.exception("frame from client %s failed", self.id)
            self.log(8, f"{op}: {type(exc).__name__}: {exc}", mid if isinstance(mid, str | int) else None)

    def _topic_type(self, topic: str, claimed: str | None) -> str:
        known = self.broker.types.get(topic)
        dialect = self.broker.dialect
        if claimed is not None and known is not None and messages.canonical(claimed) != messages.canonical(known):
            raise ProtocolError(
                f"Tried to register topic {topic} with type {claimed} but it is already established "
                f"with type {known}"
            )
        if claimed is not None and not dialect.valid_type(claimed):
            raise ProtocolError(f"Unable to import msg class {claimed}: invalid message type")
        if claimed is not None and known is None and not messages.known_package(claimed):
            package, name = claimed.split("/")[0], claimed.split("/")[-1]
            raise ProtocolError(f"Unable to import msg class {name} from package {package}. "
                                f"Caused by: No module named {package}.msg")
        if known is None and claimed is None:
            raise ProtocolError(f"Cannot infer topic type for topic {topic} as it is not yet advertised")
        return known or dialect.spell(claimed)  # type: ignore[arg-type]

    def op_advertise(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "topic", str), (True, "type", str), (False, "latch", bool),
                       (False, "queue_size", int)])
        topic = frame["topic"]
        self.broker.types[topic] = self._topic_type(topic, frame["type"])
        self.broker.publishers[topic].add(self.id)

    def op_unadvertise(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "topic", str)])
        self.broker.publishers[frame["topic"]].discard(self.id)

    def op_publish(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "topic", str), (False, "latch", bool), (False, "queue_size", int)])
        topic = frame["topic"]
        msg_type = self._topic_type(topic, None)
        raw_msg = frame.get("msg", {})
        if messages.known(msg_type):
            msg = messages.normalize(msg_type, raw_msg)
        elif isinstance(raw_msg, dict):
            msg = raw_msg  # a type the simulator has no schema for: passed through unchecked
        else:
            raise messages.ConversionError(f"Expected a dict for a {msg_type} message")
        self.broker.publishers[topic].add(self.id)
        self.broker.deliver(topic, msg, bool(frame.get("latch", False)))

    def op_subscribe(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "topic", str), (False, "type", str), (False, "throttle_rate", int),
                       (False, "fragment_size", int), (False, "queue_length", int),
                       (False, "compression", str)])
        topic = frame["topic"]
        self.broker.types[topic] = self._topic_type(topic, frame.get("type"))
        sub = self.broker.subs[topic].setdefault(self.id, Subscription(self))
        sub.params[mid] = (max(0, frame.get("throttle_rate", 0)), max(0, frame.get("queue_length", 0)))
        sub.raw = frame.get("compression") == "cbor-raw"
        sub.update()
        latched = self.broker.latched_frame(topic)
        if latched is not None:
            self.send(self.broker.dialect.raw_frame(topic, self.broker.types[topic], json.loads(latched)["msg"])
                      if sub.raw else latched)

    def op_unsubscribe(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "topic", str)])
        topic = frame["topic"]
        sub = self.broker.subs.get(topic, {}).get(self.id)
        if sub is None:
            return
        if mid is None:
            sub.params.clear()
        else:
            sub.params.pop(mid, None)
        if sub.params:
            sub.update()
        else:
            self.broker.unsubscribe(self.id, topic)

    def op_call_service(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "service", str), (False, "fragment_size", int), (False, "compression", str)])
        name = frame["service"]
        args = frame.get("args", {})
        owner = self.broker.client_services.get(name)
        if owner is not None:
            call_id = next(self.broker.call_ids)
            self.broker.pending_calls[call_id] = (self, mid, name)
            if self.broker.dialect.ros2 and not self.broker.services_in_new_thread:
                self.hold(call_id)  # a service that never answers wedges this client
            owner.reply({"op": "call_service", "id": call_id, "service": name, "args": args})
            return
        entry = self.broker.services.get(name)
        try:
            if entry is None:
                raise ServiceError(f"Service {name} does not exist")
            srv_type, handler = entry
            request = messages.normalize_request(srv_type, args)
            values: Any = handler(request)
            ok = True
        except NoAnswer:
            if self.broker.dialect.ros2 and not self.broker.services_in_new_thread:
                self.hold(("no answer", mid))  # wedged for good
            return
        except (ServiceError, messages.ConversionError) as exc:
            self.log(8, f"call_service {type(exc).__name__}: {exc}", mid)
            values, ok = str(exc), False
        self.respond(mid, name, values, ok)

    def op_advertise_service(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "service", str), (True, "type", str)])
        self.broker.client_services[frame["service"]] = self

    def op_unadvertise_service(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "service", str)])
        if self.broker.client_services.get(frame["service"]) is self:
            del self.broker.client_services[frame["service"]]

    def op_service_response(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "service", str), (True, "result", bool)])
        pending = self.broker.pending_calls.pop(mid, None)
        if pending is None:
            return
        caller, caller_id, name = pending
        caller.respond(caller_id, name, frame.get("values", {}), frame["result"])
        caller.release(mid)

    def op_fragment(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "id", str), (True, "data", str), (True, "num", int), (True, "total", int)])
        parts = self.fragments.setdefault(mid, {})
        parts[frame["num"]] = frame["data"]
        if len(parts) == frame["total"]:
            del self.fragments[mid]
            self.handle("".join(parts[i] for i in sorted(parts)))

    def op_send_action_goal(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "action", str), (True, "action_type", str), (False, "args", dict),
                       (False, "feedback", bool)])
        endpoint = self.broker.actions.get(frame["action"])
        if endpoint is None or messages.canonical(frame["action_type"]) != messages.canonical(endpoint.type):
            raise ProtocolError(f"Action {frame['action']} of type {frame['action_type']} is not available")
        if not self.broker.goals_in_new_thread:
            self.hold(("goal", mid))  # released by the goal's action_result
        try:
            endpoint.send_goal(self, mid, frame.get("args", {}))
        except Exception:
            self.release(("goal", mid))
            raise

    def op_cancel_action_goal(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "action", str)])
        endpoint = self.broker.actions.get(frame["action"])
        if endpoint is not None:
            endpoint.cancel_goal(self, mid)
