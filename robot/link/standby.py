"""A standby link can stop the robot too: the E-STOP does not wait for a failover.

The link that holds the lease is the only one that commands the robot. When it dies, the standby
takes over a lease's time later; an E-STOP pressed in between would reach nobody. So while a link
process waits for the lease it keeps a rosbridge connection of its own and listens on the direct
path (``robot.link.direct``) for the E-STOP's requests, and does only what stops the robot: a zero
Twist (repeated for the hold), and the publishes and service calls that pass the latch as the
stop's own (cancel goals, motors off, mode stop). Stopping twice is harmless; its replies say
``standby`` so a web process prefers the active link's.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from typing import Any

import roslibpy
from django.conf import settings

from robot import interface as ri
from robot.link import direct
from robot.link.guard import CmdVelGuard
from robot.link.rosclient import LinkRos, Publishers, call_service, close_quietly
from robot.live.groups import LinkReply, LinkRequest

log = logging.getLogger(__name__)

class StandbyStop:
    def __init__(self, url: str) -> None:
        self.url = url
        self.ros: roslibpy.Ros | None = None
        self._publishers = Publishers()
        self.guard: CmdVelGuard | None = None

    async def run(self) -> None:
        """Connect (and keep reconnecting) and answer on the direct path until cancelled."""
        from twisted.internet import reactor

        self.ros = LinkRos(self.url)
        self.ros.factory.maxDelay = settings.ROBOT_LINK_MAX_BACKOFF_S
        # The link's own guard, latched for good: a zero Twist (held) and what passes the latch.
        self.guard = CmdVelGuard(self._publish_zero, loop=asyncio.get_running_loop(), rate_hz=settings.TELEOP_RATE_HZ,
                                 hold_s=settings.ESTOP_HOLD_S, deadman_s=settings.TELEOP_LINK_DEADMAN_S)
        self.guard.latched = True
        if not reactor.running:
            self.ros.factory.manager.run()
        try:
            await direct.serve(self.answer)
        finally:
            self.guard.stop()
            ros, self.ros = self.ros, None
            ros.factory.stopTrying()
            if ros.is_connected:
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(asyncio.get_running_loop().run_in_executor(None, close_quietly, ros), 3)

    async def answer(self, request: LinkRequest) -> LinkReply:
        reply = await self._stop(request)
        reply["standby"] = True
        return reply

    async def _stop(self, request: LinkRequest) -> LinkReply:
        if self.ros is None or not self.ros.is_connected or self.guard is None:
            return {"ok": False, "error_code": "offline", "error": "standby link: no connection to the robot"}
        op = request.get("op")
        if op == "estop":
            self.guard.engage()
            return {"ok": True}
        name = request.get("topic") if op == "publish" else request.get("service")
        msg: dict[str, Any] = (request.get("msg") if op == "publish" else request.get("args")) or {}
        if op not in ("publish", "call_service") or self.guard.check_publish(str(name), msg, by_the_stop=True):
            return {"ok": False, "error_code": "offline", "error": "a standby link only stops the robot"}
        if op == "publish":
            self._publishers.publish(self.ros, request["topic"], request["msg_type"], msg)
            return {"ok": True}
        timeout = float(request.get("timeout") or settings.ROBOT_REQUEST_TIMEOUT_S)
        return await call_service(self.ros, request["service"], request["service_type"], msg, timeout)

    def _publish_zero(self) -> None:
        if self.ros is None or not self.ros.is_connected:
            raise RuntimeError("standby link: robot offline")
        cmd_vel = ri.topic("cmd_vel")
        self._publishers.publish(self.ros, cmd_vel.name, cmd_vel.type, ri.ZERO_TWIST)
