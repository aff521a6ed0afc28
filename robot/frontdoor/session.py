"""One ROS tool's connection through the front door: its subscriptions, publishes and calls.

Subscriptions come from the process's hub (``robot.live.hub``) under the topic's ``whole:`` key, held
at the link by the process's one lease per topic (``robot.link.topicwatch``): one upstream
subscription however many tools and pages watch. Each client paces what it gets itself (a
``Coalescer`` of its own): its ``throttle_rate``, or for a client that asks none (Foxglove) the
topic's front-door pace; a slow client's oldest messages go, nobody else waits for it. A topic it
takes every message of keeps at most its ``queue_length`` waiting (as rosbridge's queue: the
oldest dropped), or with none asked at most ``MAX_BACKLOG`` of all its topics together.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import weakref
from collections.abc import Awaitable, Callable
from typing import Any

from django.conf import settings

from robot import interface as ri
from robot.commands.audit_writer import writer
from robot.commands.pipeline import arun
from robot.frontdoor import encoding
from robot.frontdoor import protocol as p
from robot.frontdoor.rules import Refused, call_command, drive_input, is_cmd_vel, publish_command, rosapi_type
from robot.link.bus import RobotError, arequest
from robot.link.topicwatch import TopicRefused, local_watches
from robot.link.watching import WHOLE_PREFIX, whole_key
from robot.live.fanout import Coalescer
from robot.live.feed import alocal_hub
from robot.live.frames import update_fragment
from robot.live.hub import FrameWriter, Hub, Socket
from robot.live.state import get_store
from robot.teleop.driver import Driver

log = logging.getLogger(__name__)

Send = Callable[[str | bytes], Awaitable[None]]
WRITE_POLL_S = 0.005
# A client whose connection holds more than this not yet taken by the kernel gets nothing more until it
# has: its coalescer keeps the newest of each paced topic and drops the oldest of the rest meanwhile.
MAX_UNSENT = 64 * 1024
MAX_BACKLOG = 1000  # per client: every-message updates kept while it is slow (oldest dropped)
# The last message of each latched topic this process's tools take, by hub (one per event loop): a tool
# subscribing while another one here takes it already gets it at once (the link sends it to a
# process's first only), as the robot's rosbridge would, from the one upstream subscription.
_latched: weakref.WeakKeyDictionary[Hub, dict[str, str]] = weakref.WeakKeyDictionary()


async def _nothing(text: str | bytes) -> None:
    return None


class DoorSocket(Socket):
    """A hub socket that hands each update to its session instead of waiting for the hub's frames."""

    framed = False

    def __init__(self, on_update: Callable[[str, str], None]) -> None:
        super().__init__(_nothing)
        self.on_update = on_update

    def offer(self, key: str, fragment: str, t: float, every: bool) -> None:
        self.on_update(key.removeprefix(WHOLE_PREFIX), fragment)

    def take(self) -> list[str | tuple[str, ...]]:
        return []


def pace_hz(topic: str, paces: dict[str, float]) -> float | None:
    """How often a client asking no throttle gets ``topic``: the admin's pace, else ``FRONTDOOR_PACE_HZ``
    for the robot's high-rate topics and every message for the rest. None: every message."""
    if topic in paces:
        return paces[topic] or None
    fast = any(t.name == topic and t.ui_rate_hz is not None for t in ri.topics())
    return settings.FRONTDOOR_PACE_HZ if fast else None


def _sensitive(topic: str) -> str:
    return f"{topic} is sensitive: operators only"


class Session:
    def __init__(self, *, user: Any, operator: bool, owner: str, send: Send, writer: FrameWriter | None = None,
                 sensitive: set[str] | None = None, paces: dict[str, float] | None = None,
                 topics: set[str] | None = None, services: set[str] | None = None) -> None:
        self.user = user
        self.operator = operator
        self._send = send
        self._writer = writer
        self.sensitive = sensitive or set()  # the topics this person may not watch
        self.paces = paces or {}
        self.allowed_topics = topics or set()
        self.allowed_services = services or set()
        self.subs: dict[str, dict[str | None, p.Subscribe]] = {}  # topic -> subscription id -> options
        self.rates: dict[str, float | None] = {}
        self.queue_lengths: dict[str, int] = {}  # topic -> how many of its messages may wait (0: no limit of its own)
        self.compression: dict[str, str] = {}  # topic -> none | cbor | cbor-raw (its latest subscription's)
        self.latched: set[str] = set()  # the latched topics it takes (their last message kept for the process)
        self._latest: dict[str, str] = {}
        self.fragment_size: dict[str, int] = {}  # topic -> the largest text frame before it goes in fragments
        self._fragments = itertools.count()
        self._waiting = False  # a frame waits for the client to take what it has (the order holds)
        self.advertised: dict[str, str] = {}
        self.driver = Driver(user=user, owner=owner, can_drive=operator, send=self._driver_said)
        self.hub: Hub | None = None
        self.socket = DoorSocket(self._on_update)
        self.coalescer: Coalescer | None = None

    async def start(self) -> None:
        self.hub = await alocal_hub()
        self.hub.add(self.socket)
        self._latest = _latched.setdefault(self.hub, {})
        self.coalescer = Coalescer(self._write, loop=asyncio.get_running_loop(), max_backlog=MAX_BACKLOG,
                                   write_now=self._write_now)

    async def close(self) -> None:
        if self.hub is not None:
            self.hub.detach(self.socket)
        if self.coalescer is not None:
            self.coalescer.close()
        await local_watches().drop(self.socket)
        await self.driver.close()

    # --- frames from the client ----------------------------------------------------------

    async def handle(self, text: str | bytes) -> None:
        frame: dict[str, Any] = {}
        try:
            frame = p.parse(text)
            handler = {
                "subscribe": self._subscribe, "unsubscribe": self._unsubscribe, "advertise": self._advertise,
                "unadvertise": self._unadvertise, "publish": self._publish, "call_service": self._call,
            }.get(frame["op"])
            if handler is None:
                raise p.BadFrame(f"op {frame['op']!r} is not served by the front door")
            await handler(frame)
        except p.BadFrame as exc:
            await self._status("error", f"{frame.get('op', 'frame')}: {exc}", p.frame_id(frame))
        except Refused as exc:
            await self._status("error", f"{frame.get('op')}: {exc.message}", p.frame_id(frame))
        except RobotError as exc:
            await self._status("error", f"{frame.get('op')}: {exc.message}", p.frame_id(frame))

    async def _subscribe(self, frame: dict[str, Any]) -> None:
        sub = p.subscribe(frame)
        if sub.compression == "png":
            raise p.BadFrame("png compression is not served: subscribe with none, cbor or cbor-raw")
        if sub.topic in self.sensitive:
            raise Refused(_sensitive(sub.topic))
        if sub.compression == "cbor-raw":
            await encoding.learn(sub.topic)
        first = sub.topic not in self.subs
        self.subs.setdefault(sub.topic, {})[sub.id] = sub
        self.compression[sub.topic] = sub.compression
        sizes = [s.fragment_size for s in self.subs[sub.topic].values() if s.fragment_size]
        if sizes:
            self.fragment_size[sub.topic] = min(sizes)
        else:
            self.fragment_size.pop(sub.topic, None)
        self._set_rate(sub.topic)
        if not first:
            return
        assert self.hub is not None
        key = whole_key(sub.topic)
        self.hub.watch(self.socket, [key])  # listening before the link answers (a latched topic's message)
        if sub.topic in ri.latched_names():
            self.latched.add(sub.topic)
        shared = bool(local_watches().whole.get(sub.topic))
        try:
            await local_watches().watch(self.socket, sub.topic, whole=True)
        except TopicRefused as exc:
            if exc.code != "offline":  # offline: the watch stays and works once the robot is back
                self.subs.pop(sub.topic, None)
                self.latched.discard(sub.topic)
                self.hub.unwatch(self.socket, [key])
            raise Refused(f"{sub.topic}: {exc.message}", exc.code) from None
        latest = self._latest.get(sub.topic) if shared and sub.topic in self.latched else None
        if latest is not None:
            self._on_update(sub.topic, latest)
            return
        stored = (await get_store().aget_many([key])).get(key)
        if stored is not None and not self.socket.pending:
            self._on_update(sub.topic, update_fragment(stored))

    async def _unsubscribe(self, frame: dict[str, Any]) -> None:
        topic = str(p.text(frame, "topic"))
        subs = self.subs.get(topic)
        if subs is None:
            return
        sub_id = p.frame_id(frame)
        if sub_id is None or sub_id not in subs:
            subs.clear()  # rosbridge: without (a known) id, every subscription of this client to the topic
        else:
            del subs[sub_id]
        if subs:
            self._set_rate(topic)
            return
        del self.subs[topic]
        self.latched.discard(topic)
        self.rates.pop(topic, None)
        self.queue_lengths.pop(topic, None)
        self.compression.pop(topic, None)
        self.fragment_size.pop(topic, None)
        assert self.hub is not None
        self.hub.unwatch(self.socket, [whole_key(topic)])
        await local_watches().unwatch(self.socket, topic, whole=True)

    async def configure(self, *, sensitive: set[str], paces: dict[str, float], topics: set[str],
                        services: set[str]) -> None:
        """What an admin set changed: paces, allowlist and sensitive topics apply from now on; a
        subscription to a topic now sensitive ends with a status error naming why."""
        self.sensitive, self.paces, self.allowed_topics, self.allowed_services = sensitive, paces, topics, services
        for topic in list(self.subs):
            if topic in sensitive:
                await self._unsubscribe({"topic": topic})
                await self._status("error", f"subscribe: {_sensitive(topic)}")
            else:
                self._set_rate(topic)

    def _set_rate(self, topic: str) -> None:
        """One pace and queue per topic per client: the smallest throttle and queue_length of its
        subscriptions win (as rosbridge)."""
        throttle = min(s.throttle_rate for s in self.subs[topic].values())
        self.rates[topic] = 1000.0 / throttle if throttle else pace_hz(topic, self.paces)
        self.queue_lengths[topic] = min(s.queue_length for s in self.subs[topic].values())

    async def _advertise(self, frame: dict[str, Any]) -> None:
        topic, msg_type = str(p.text(frame, "topic")), str(p.text(frame, "type"))
        if not self.operator:
            raise Refused("viewers may not publish (operators and admins can)")
        self.advertised[topic] = msg_type

    async def _unadvertise(self, frame: dict[str, Any]) -> None:
        topic = str(p.text(frame, "topic"))
        if self.advertised.pop(topic, None) is not None and is_cmd_vel(topic):
            await self.driver.handle({"type": "release"})

    async def _publish(self, frame: dict[str, Any]) -> None:
        topic, msg = str(p.text(frame, "topic")), frame.get("msg")
        if not self.operator:
            await self._audit_refusal("frontdoor.publish", {"topic": topic}, "viewers may not publish")
            raise Refused("viewers may not publish (operators and admins can)")
        if is_cmd_vel(topic):
            await self.driver.handle(drive_input(msg))
            return
        command = publish_command(user=self.user, topic=topic, msg_type=self.advertised.get(topic), msg=msg,
                                  allowed=self.allowed_topics)
        await arun(command, user=self.user, source="frontdoor")

    async def _call(self, frame: dict[str, Any]) -> None:
        service, call_id = str(p.text(frame, "service")), p.frame_id(frame)
        try:
            args = p.args(frame)
            values = await self._call_values(service, frame.get("type"), args)
        except (Refused, RobotError, p.BadFrame) as exc:
            message = exc.message if isinstance(exc, Refused | RobotError) else str(exc)
            await self._send(p.service_response(service, call_id, message, False))
            if not isinstance(exc, RobotError) or exc.code != "failed":
                await self._status("error", f"call_service {service}: {message}", call_id)
            return
        await self._send(p.service_response(service, call_id, values, True))

    async def _call_values(self, service: str, service_type: Any, args: dict[str, Any]) -> Any:
        rosapi = rosapi_type(service)
        if rosapi is not None:
            reply = await arequest("call_service", service=service, service_type=rosapi, args=args)
            return reply.get("values")
        if not self.operator:
            await self._audit_refusal("frontdoor.call", {"service": service}, "viewers may only call rosapi's "
                                                                               "read-only services")
            raise Refused("viewers may only call rosapi's read-only services (operators may call more)")
        command = call_command(service=service, service_type=service_type if isinstance(service_type, str) else None,
                               args=args, allowed=self.allowed_services)
        await arun(command, user=self.user, source="frontdoor")
        return command.result.get("values", {})

    # --- what goes to the client ---------------------------------------------------------

    def _on_update(self, topic: str, fragment: str) -> None:
        if topic in self.latched:
            self._latest[topic] = fragment
        if topic in self.subs and self.coalescer is not None:
            compression = self.compression.get(topic, "none")
            frame: str | bytes | tuple[str, ...] | None = p.publish_from_fragment(topic, fragment) \
                if compression == "none" else encoding.frame(topic, fragment, compression)
            size = self.fragment_size.get(topic)
            if size and isinstance(frame, str) and len(frame) > size:
                frame = tuple(p.fragments(frame, size, f"{topic}:{next(self._fragments)}"))
            if frame is not None:
                self.coalescer.offer(topic, self.rates.get(topic), frame, self.queue_lengths.get(topic, 0))

    async def _write(self, frame: str | bytes | tuple[str, ...]) -> None:
        """One frame, once the client took the previous one (meanwhile its coalescer drops the oldest).
        Under Daphne written straight to the connection, encoded once for every client that gets it."""
        if isinstance(frame, tuple):  # a message in fragments
            for part in frame:
                await self._write(part)
            return
        if self._writer is None:
            await self._send(frame)
            return
        self._waiting = True
        try:
            while (backlog := self._writer.backlog()) > MAX_UNSENT:
                await asyncio.sleep(WRITE_POLL_S)
        finally:
            self._waiting = False
        if backlog >= 0:  # (below: closing)
            self._writer.write(encoding.encoded(frame))

    def _write_now(self, frame: str | bytes | tuple[str, ...]) -> bool:
        """Under Daphne, a frame nothing waits before goes out in the hub's own turn (no task switch)."""
        if self._writer is None or self._waiting or isinstance(frame, tuple):
            return False
        backlog = self._writer.backlog()
        if backlog > MAX_UNSENT:
            return False
        if backlog >= 0:
            self._writer.write(encoding.encoded(frame))
        return True

    async def _status(self, level: str, msg: str, id: str | None = None) -> None:
        await self._send(p.status(level, msg, id))

    async def _driver_said(self, message: dict[str, Any]) -> None:
        kind = message.get("type")
        if kind == "error":
            await self._status("error", f"publish {ri.topic('cmd_vel').name}: {message.get('message')}")
        elif kind == "notice":
            await self._status("warning", str(message.get("message")))
        elif kind == "commanded" and message.get("reason"):
            await self._status("warning", f"{ri.topic('cmd_vel').name}: robot stopped ({message['reason']})")

    async def _audit_refusal(self, action: str, params: dict[str, Any], why: str) -> None:
        await writer.record(user=self.user, source="frontdoor", action=action, params=params, ok=False,
                            outcome=why, error_code="forbidden")
