"""The link's upstream subscriptions: one rosbridge subscription per topic however many hold it,
and each message's way to the store and the browsers (or to a handler registered for its key)."""

from __future__ import annotations

import asyncio
import logging
import re
import threading
import time
from collections.abc import Awaitable, Callable, Coroutine, Iterable
from typing import Any

import roslibpy

from robot import interface as ri
from robot.link.dial import Dial
from robot.link.dialect import ask_ros_version, to_model
from robot.link.nav2 import Ros2Goals
from robot.live.announce import aannounce
from robot.live.fanout import Coalescer
from robot.live.groups import TopicUpdate
from robot.live.state import StateStore

log = logging.getLogger(__name__)

# (topic name, type, message, receive time) for every message on every subscribed topic.
Listener = Callable[[str, str, dict[str, Any], float], None]
# ROS 1 rosbridge answers a subscription it cannot make (a message package the robot lacks) only on
# /rosout, as an error from its own node naming the request id roslibpy gave it.
ROSBRIDGE_NODE = "/rosbridge_websocket"
_FAILED_SUBSCRIBE = re.compile(r"\[id: subscribe:(?P<topic>/[^\]]*?):\d+\] subscribe: (?P<error>.*)", re.S)

# Per-key handlers replace the generic store/fan-out path (e.g. the map renderer).
Handler = Callable[[ri.Topic, dict[str, Any], float], Awaitable[None] | None]

_handlers: dict[str, Handler] = {}
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


def array_topics() -> frozenset[str]:
    return frozenset(ri.topic(key).name for key in _array_keys)


class Subscriptions:
    """Who holds each upstream subscription (the registry, the recorder, watching pages, the microphone,
    ...), the rosbridge subscriptions they hold, and where each message goes."""

    def __init__(self, dial: Dial, *, store: StateStore, topics: Iterable[ri.Topic] | None, nav2: Ros2Goals,
                 service_timeout_s: float, spawn: Callable[[Coroutine[Any, Any, Any]], object],
                 changed: Callable[[], None]) -> None:
        self.dial = dial
        self.store = store
        self.nav2 = nav2
        self.service_timeout_s = service_timeout_s
        self.topics = list(topics if topics is not None else ri.monitored_topics())
        self.listeners: list[Listener] = []
        # Subscriptions the robot refused since the last (re)connect: topic -> rosbridge's reason.
        # roslibpy sends every subscription again on each reconnect; a refusal then is reported again.
        self.failed: dict[str, str] = {}
        self._spawn = spawn
        self._changed = changed  # what the status shows changed
        self._subscriptions: dict[str, roslibpy.Topic] = {}
        # The subscription goes when its last holder lets go.
        self._holders: dict[str, set[str]] = {}
        self._was_ready = False  # a connection was ready before (the next one subscribes again)
        self._coalescer: Coalescer | None = None

    def start(self) -> None:
        assert self.dial.loop is not None
        self._coalescer = Coalescer(self._send_update, loop=self.dial.loop)
        for t in self.topics:
            self.subscribe(t.name, t.type, holder=REGISTRY_HOLDER)

    def stop(self) -> asyncio.Task | None:
        """Subscribe no more (the connection closes next); the task that sends the last updates."""
        for topic in self._subscriptions.values():
            topic.reconnect_on_close = False
        return self._coalescer.close() if self._coalescer is not None else None

    def goal_status(self, msg: dict[str, Any]) -> None:
        """A ROS 2 goal's status from its own connection, into the model as the robot's status topic."""
        self.dial.threadsafe(self._on_message, ri.topic("move_base_status").name, "actionlib_msgs/GoalStatusArray",
                             msg, time.time())

    def ready(self) -> None:
        self.failed.clear()  # roslibpy subscribes again now; refusals come back on /rosout
        if ri.configured_ros() is None:
            self._spawn(self._find_ros())

    async def _find_ros(self) -> None:
        """Ask the robot which ROS it runs; on a change, use that ROS's names and subscribe by them."""
        ros = self.dial.ros
        if ros is None:
            return
        version, why = await ask_ros_version(ros, self.service_timeout_s)
        if version is None:
            log.warning("could not find out which ROS the robot runs (%s); using ROS %d", why, self.dial.ros_version)
            return
        ri.use_ros(version)
        if version == self.dial.ros_version:
            return
        log.info("the robot runs ROS %d: using its names", version)
        old, self.dial.ros_version = self.topics, version
        self.topics = list(ri.monitored_topics())
        for t in old:
            self.unsubscribe(t.name, holder=REGISTRY_HOLDER)
        for t in self.topics:
            self.subscribe(t.name, t.type, holder=REGISTRY_HOLDER)
        self._changed()

    def _note_refusal(self, text: str) -> None:
        refused = _FAILED_SUBSCRIBE.search(text)
        if refused is None or refused["topic"] not in self._subscriptions:
            return
        first = refused["topic"] not in self.failed
        self.failed[refused["topic"]] = refused["error"].strip()
        if first:
            log.error("the robot refused the subscription to %s (tried again on every reconnect): %s",
                      refused["topic"], refused["error"].strip())
            self._changed()

    def received(self, name: str, msg_type: str, msg: dict[str, Any]) -> None:
        """A topic message, on the reactor thread: handled at once when that is the loop's own
        thread (Daphne), not a self-pipe wake-up and a loop turn later."""
        t = time.time()
        if threading.get_ident() != self.dial.loop_thread:
            self.dial.threadsafe(self._on_message, name, msg_type, msg, t)
            return
        try:
            self._on_message(name, msg_type, msg, t)
        except Exception:  # never into roslibpy's read: the connection must survive a bad message
            log.exception("handling a message on %s failed", name)

    def subscribe(self, name: str, msg_type: str, *, holder: str = PINNED_HOLDER) -> None:
        """Hold the upstream subscription to ``name`` for ``holder``: one rosbridge subscription per
        topic however many holders; later calls for the same topic only add the holder."""
        if self.dial.ros is None:
            return
        self._holders.setdefault(name, set()).add(holder)
        if name in self._subscriptions:
            return
        topic = roslibpy.Topic(self.dial.ros, name, msg_type, reconnect_on_close=False)  # see resubscribe
        topic.subscribe(lambda msg, _n=name, _t=msg_type: self.received(_n, _t, msg))
        self._subscriptions[name] = topic

    def resubscribe(self, proto: Any) -> None:
        """A new connection, on the reactor's thread before anything else goes out on it: subscribe again
        at once. roslibpy would do it a second after the old connection closed, and what the robot says
        meanwhile (the state_change answering a command sent at once) would never arrive."""
        if not self._was_ready:
            self._was_ready = True  # the first connection sends the subscriptions queued for it
            return
        for topic in list(self._subscriptions.values()):
            proto.send_ros_message(topic._connect_message)

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

    @property
    def subscribed(self) -> set[str]:
        return set(self._subscriptions)

    def _on_message(self, name: str, msg_type: str, msg: dict[str, Any], t: float) -> None:
        if self.dial.stopped:
            return
        self.dial.heard_at = t
        msg = to_model(self.dial.ros_version, msg_type, msg)
        if self.dial.ros_version == ri.ROS2 and name in (ri.topic("move_base_status").name,
                                                         ri.topic("navigation_status").name):
            msg = self.nav2.name_goals(msg, name)
        if name == ri.topic("rosout").name and msg.get("name") == ROSBRIDGE_NODE:
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
        update: TopicUpdate = {
            "type": "robot.update", "key": topic.key, "topic": name, "msg_type": msg_type, "msg": msg, "t": t,
        }
        assert self._coalescer is not None
        self._coalescer.offer(topic.key, topic.ui_rate_hz, update)

    async def _send_update(self, update: TopicUpdate) -> None:
        key = update["key"]
        await aannounce(key, dict(update), recent=ri.topic(key).recent, store=self.store)
