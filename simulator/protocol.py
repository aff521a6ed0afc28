"""The rosbridge v2 protocol as the ROS 1 rosbridge_server (and, with the ROS 2 dialect, the ROS 2 one) speaks it.

``RosbridgeServer`` accepts websocket clients; ``Client`` is one connection and its rosbridge
session on the ROS graph (``bus.Bus``). Frames a client gets wrong are logged (ERROR on
/rosout from /rosbridge_websocket) and dropped: neither server answers with ``status`` frames.

The ROS 2 server's launch defaults handle one op of a client at a time: a goal it sent, or a
call of a service another client serves, holds that client's later frames until it ends
(``goals_in_new_thread`` / ``services_in_new_thread`` lift that, as the launch arguments do).
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed

from . import messages
from .bus import Bus, NoAnswer, ServiceError

log = logging.getLogger("simulator.rosbridge")



class ProtocolError(Exception):
    """A frame rosbridge would refuse; logged and dropped."""


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

    def __init__(self, bus: Bus, send: Callable[[str | bytes], Any], address: str = "") -> None:
        self.bus = bus
        self.id = next(bus.client_ids)
        self.address = address
        self.connected_at = time.time()
        self._send = send  # coroutine function: await send(text)
        self.outbox: asyncio.Queue[str | bytes] = asyncio.Queue()
        self.closed = False
        self.fragments: dict[Any, dict[int, str]] = {}
        self.ops = self.OPS + (self.ACTION_OPS if bus.dialect.ros2 else ())
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
        self.send(self.bus.encode(frame))

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
        self.bus.rosout(level, "/rosbridge_websocket", f"{prefix} {text}")

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
        known = self.bus.types.get(topic)
        dialect = self.bus.dialect
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
        self.bus.types[topic] = self._topic_type(topic, frame["type"])
        self.bus.publishers[topic].add(self.id)

    def op_unadvertise(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "topic", str)])
        self.bus.publishers[frame["topic"]].discard(self.id)

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
        self.bus.publishers[topic].add(self.id)
        self.bus.deliver(topic, msg, bool(frame.get("latch", False)))

    def op_subscribe(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "topic", str), (False, "type", str), (False, "throttle_rate", int),
                       (False, "fragment_size", int), (False, "queue_length", int),
                       (False, "compression", str)])
        topic = frame["topic"]
        self.bus.types[topic] = self._topic_type(topic, frame.get("type"))
        sub = self.bus.subs[topic].setdefault(self.id, Subscription(self))
        sub.params[mid] = (max(0, frame.get("throttle_rate", 0)), max(0, frame.get("queue_length", 0)))
        sub.raw = frame.get("compression") == "cbor-raw"
        sub.update()
        latched = self.bus.latched_frame(topic)
        if latched is not None:
            self.send(self.bus.dialect.raw_frame(topic, self.bus.types[topic], json.loads(latched)["msg"])
                      if sub.raw else latched)

    def op_unsubscribe(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "topic", str)])
        topic = frame["topic"]
        sub = self.bus.subs.get(topic, {}).get(self.id)
        if sub is None:
            return
        if mid is None:
            sub.params.clear()
        else:
            sub.params.pop(mid, None)
        if sub.params:
            sub.update()
        else:
            self.bus.unsubscribe(self.id, topic)

    def op_call_service(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "service", str), (False, "fragment_size", int), (False, "compression", str)])
        name = frame["service"]
        args = frame.get("args", {})
        owner = self.bus.client_services.get(name)
        if owner is not None:
            call_id = next(self.bus.call_ids)
            self.bus.pending_calls[call_id] = (self, mid, name)
            if self.bus.dialect.ros2 and not self.bus.services_in_new_thread:
                self.hold(call_id)  # a service that never answers wedges this client
            owner.reply({"op": "call_service", "id": call_id, "service": name, "args": args})
            return
        entry = self.bus.services.get(name)
        try:
            if entry is None:
                raise ServiceError(f"Service {name} does not exist")
            srv_type, handler = entry
            request = messages.normalize_request(srv_type, args)
            values: Any = handler(request)
            ok = True
        except NoAnswer:
            if self.bus.dialect.ros2 and not self.bus.services_in_new_thread:
                self.hold(("no answer", mid))  # wedged for good
            return
        except (ServiceError, messages.ConversionError) as exc:
            self.log(8, f"call_service {type(exc).__name__}: {exc}", mid)
            values, ok = str(exc), False
        self.respond(mid, name, values, ok)

    def op_advertise_service(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "service", str), (True, "type", str)])
        self.bus.client_services[frame["service"]] = self

    def op_unadvertise_service(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "service", str)])
        if self.bus.client_services.get(frame["service"]) is self:
            del self.bus.client_services[frame["service"]]

    def op_service_response(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "service", str), (True, "result", bool)])
        pending = self.bus.pending_calls.pop(mid, None)
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
        endpoint = self.bus.actions.get(frame["action"])
        if endpoint is None or messages.canonical(frame["action_type"]) != messages.canonical(endpoint.type):
            raise ProtocolError(f"Action {frame['action']} of type {frame['action_type']} is not available")
        if not self.bus.goals_in_new_thread:
            self.hold(("goal", mid))  # released by the goal's action_result
        try:
            endpoint.send_goal(self, mid, frame.get("args", {}))
        except Exception:
            self.release(("goal", mid))
            raise

    def op_cancel_action_goal(self, frame: dict[str, Any], mid: Any) -> None:
        _check(frame, [(True, "action", str)])
        endpoint = self.bus.actions.get(frame["action"])
        if endpoint is not None:
            endpoint.cancel_goal(self, mid)


class RosbridgeServer:
    def __init__(self, bus: Bus, clients_changed: Callable[[], None]) -> None:
        self.bus = bus
        self.clients_changed = clients_changed
        self.server: Server | None = None
        self.port = 0
        self.connections: set[ServerConnection] = set()

    async def start(self, host: str, port: int) -> None:
        # rosbridge: no permessage-deflate, no pings, no practical frame size limit
        self.server = await serve(
            self._handle, host, port, compression=None, ping_interval=None, max_size=2**28,
            max_queue=None, close_timeout=1.0, reuse_address=True,
        )
        self.port = self.server.sockets[0].getsockname()[1]

    async def stop(self) -> None:
        if self.server is None:
            return
        self.server.close(close_connections=False)
        for ws in list(self.connections):
            ws.transport.abort()  # the robot vanishing: clients see the TCP connection drop
        try:
            await asyncio.wait_for(self.server.wait_closed(), 3.0)
        except TimeoutError:
            log.warning("websocket server did not close within 3 s")

    async def _handle(self, ws: ServerConnection) -> None:
        self.connections.add(ws)
        bus = self.bus
        address = ws.remote_address[0] if ws.remote_address else ""
        client = Client(bus, ws.send, address)
        bus.clients[client.id] = client
        self.clients_changed()
        writer = asyncio.get_running_loop().create_task(self._write(client))
        try:
            async for raw in ws:
                client.handle(raw)
        except ConnectionClosed:
            pass
        finally:
            client.closed = True
            writer.cancel()
            self.connections.discard(ws)
            bus.disconnect(client)
            self.clients_changed()

    @staticmethod
    async def _write(client: Client) -> None:
        with contextlib.suppress(ConnectionClosed):
            await client.run_writer()
