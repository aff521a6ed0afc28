"""Requests to the link from web processes and tasks: the request loop, the replies, and the
last checks before the robot (the lease's fencing, the E-STOP latch)."""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Awaitable, Callable
from typing import Any, cast

from robot import interface as ri
from robot.link.dial import Dial
from robot.link.guard import RELEASE_FIRST
from robot.link.lease import Lease
from robot.link.nav2 import Ros2Goals
from robot.link.rosclient import Publishers, call_service
from robot.link.status import LatchWatch
from robot.live import queues
from robot.live.groups import LinkReply, LinkRequest

log = logging.getLogger(__name__)

# Between two reconnects asked for (the pages' button, the API): more often only flaps the link,
# and a flapping link cannot carry an E-STOP.
RECONNECT_INTERVAL_S = 5.0
REPLY_MARGIN_S = 0.3
_NO_ROBOT_NEEDED = frozenset({"ping", "reconnect", "estop_release"})  # answered at once

# Extra link operations other modules add (e.g. robot/audio/link.py): (link, request) -> reply,
# the link being the whole RobotLink (robot.link.connection), which holds this part.
Operation = Callable[[Any, LinkRequest], Awaitable[LinkReply]]
_operations: dict[str, Operation] = {}


def register_operation(op: str, operation: Operation) -> None:
    _operations[op] = operation


class Requests:
    """What the link is asked to do, and the last checks before the robot."""

    def __init__(self, dial: Dial, latch: LatchWatch, *, queue: str, lease: Lease | None, nav2: Ros2Goals,
                 service_timeout_s: float, owner: object, spawn: Callable[[Any], object]) -> None:
        self.dial = dial
        self.latch = latch
        self.request_queue = queue  # requests arrive on this queue (robot.live.queues)
        # Scaled mode: the Redis lease this link holds; it publishes only while the lease is still its own.
        self.lease = lease
        self.nav2 = nav2
        self.service_timeout_s = service_timeout_s
        self.owner = owner  # what registered operations are given (the whole link)
        self._spawn = spawn
        self.serving: asyncio.Future | None = None
        self._publishers = Publishers()
        self._in_order = asyncio.Lock()  # publishes one at a time through the fencing check
        self._asked_reconnect_at = -RECONNECT_INTERVAL_S  # monotonic

    async def serve(self) -> None:
        while not self.dial.stopped:
            request = await queues.pop(self.request_queue)
            if request is None:
                continue
            if request.get("type") == "link.stop":
                if self.dial.stopped:
                    return
                continue  # a stale stop message from an earlier link
            self._spawn(self.handle(cast(LinkRequest, request)))

    async def answer(self, request: LinkRequest) -> LinkReply | None:
        """``execute`` for a request that came from another process; None if it came too late."""
        deadline = request.get("deadline", float("inf"))
        if deadline < time.time():
            log.warning("dropped a %s request that arrived after its deadline", request.get("op"))
            return None
        # A link just started (a standby taking over) serves requests queued meanwhile once connected,
        # or still says "offline" in time for the caller to hear it.
        while (not self.dial.connected and request.get("op") not in _NO_ROBOT_NEEDED
               and time.time() < min(deadline - REPLY_MARGIN_S, self.dial.connecting_until)):
            await asyncio.sleep(0.02)
        return await self.execute(request)

    async def handle(self, request: LinkRequest) -> None:
        reply = await self.answer(request)
        if reply is None:
            return
        reply.update({"type": "link.reply", "request_id": request.get("request_id", "")})
        if reply_to := request.get("reply_to"):
            await queues.push(reply_to, dict(reply))

    async def execute(self, request: LinkRequest) -> LinkReply:
        op = request.get("op")
        if op == "reconnect":
            wait = self._asked_reconnect_at + RECONNECT_INTERVAL_S - time.monotonic()
            if wait > 0:
                return {"ok": False, "error_code": "throttled",
                        "error": f"The robot link reconnected moments ago; try again in {max(1, round(wait))} s."}
            self._asked_reconnect_at = time.monotonic()
            self.dial.reconnect()
            return {"ok": True}
        if op == "ping":
            return {"ok": True}
        if op in _operations:
            return await _operations[op](self.owner, request)
        guard = self.latch.guard
        if op == "estop_release":
            if guard is not None:
                guard.release()
            return {"ok": True}
        if op == "estop" and guard is not None:
            guard.engage()  # latched even when the robot is offline
            self.latch.pressed(float(request.get("at") or time.time()), str(request.get("by") or ""))
        ros = self.dial.ros
        if not self.dial.connected or ros is None or not ros.is_connected:
            return _offline(self.dial.url)
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
            if ri.is_hidden(request["topic"]):
                return {"ok": False, "error_code": "forbidden",
                        "error": f"{request['topic']} is a hidden ROS 2 name: it can be watched, never published to"}
            refused = self._held_back(request, request["topic"], request["msg"])
            if refused:
                return refused
            routed = self.dial.ros_version == ri.ROS2 and await self.nav2.publish(request["topic"], request["msg"])
            if routed:
                return routed
            assert self.dial.ros is not None
            self._publishers.publish(self.dial.ros, request["topic"], request["msg_type"], request["msg"])
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
        if self.latch.guard is None:
            return None
        refusal = self.latch.guard.check_publish(name, msg, by_the_stop=bool(request.get("stopping")),
                                           fresh_press=bool(request.get("fresh_press")))
        if refusal is None:
            return None
        return {"ok": False, "error_code": "release_first" if refusal == RELEASE_FIRST else "estop", "error": refusal}

    def publish_zero(self) -> None:
        ros = self.dial.ros
        if ros is None or not ros.is_connected:
            raise RuntimeError("robot offline")
        if self.lease is not None and not self.lease.may_stop:
            raise RuntimeError("this robot link no longer holds the lease")
        cmd_vel = ri.topic("cmd_vel")
        self._publishers.publish(ros, cmd_vel.name, cmd_vel.type, ri.ZERO_TWIST)

    async def call(self, service: ri.Service, args: dict[str, Any] | None = None, *,
                   timeout: float | None = None) -> LinkReply:
        """Call one of the robot's services from where the link runs (never blocks the loop)."""
        if not self.dial.connected or self.dial.ros is None:
            return _offline(self.dial.url)
        request: LinkRequest = {"service": service.name, "service_type": service.type, "args": args or {}}
        if timeout is not None:
            request["timeout"] = timeout
        return await self._call_service(request)

    async def _call_service(self, request: LinkRequest) -> LinkReply:
        refused = self._held_back(request, request["service"], request.get("args") or {})
        if refused:
            return refused
        assert self.dial.ros is not None
        timeout = float(request.get("timeout") or self.service_timeout_s)
        return await call_service(self.dial.ros, request["service"], request["service_type"], request.get("args") or {},
                                  timeout)


def _offline(url: str) -> LinkReply:
    return {"ok": False, "error_code": "offline", "error": f"Robot offline: no connection to {url}"}
