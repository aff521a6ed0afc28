"""A standby link can stop the robot too: the E-STOP does not wait for a failover.

The link that holds the lease is the only one that commands the robot. When it dies, the standby
takes over a lease's time later; an E-STOP pressed in between would reach nobody. So while a link
process waits for the lease it keeps a rosbridge connection of its own and listens on the direct
path (``robot.link.direct``) for the E-STOP's requests, and does only what stops the robot: a zero
Twist (repeated for the hold), and the publishes and service calls that pass the latch as the
stop's own (cancel goals, motors off, mode stop). Stopping twice is harmless; its replies say
``standby`` so a web process prefers the active link's. It speaks the robot's ROS, found out as the
link does: on ROS 2 its zero Twist has ROS 2's type and a cancel goes to Nav2's cancel service.
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
from robot.link.dialect import ask_ros_version
from robot.link.guard import CmdVelGuard
from robot.link.nav2 import Ros2Goals
from robot.link.rosclient import LinkRos, Publishers, call_service, close_quietly
from robot.live.groups import LinkReply, LinkRequest

log = logging.getLogger(__name__)

class StandbyStop:
    def __init__(self, url: str) -> None:
        self.url = url
        self.ros: roslibpy.Ros | None = None
        self._publishers = Publishers()
        self.guard: CmdVelGuard | None = None
        self.ros_version = ri.ros_version()
        self.nav2 = Ros2Goals(url, lambda: self.ros, settings.ROBOT_REQUEST_TIMEOUT_S)

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
        finding = asyncio.create_task(self._find_ros())
        try:
            await direct.serve(self.answer)
        finally:
            finding.cancel()
            self.guard.stop()
            ros, self.ros = self.ros, None
            ros.factory.stopTrying()
            if ros.is_connected:
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(asyncio.get_running_loop().run_in_executor(None, close_quietly, ros), 3)

    async def _find_ros(self) -> None:
        """Which ROS the robot runs: ROBOT_ROS, else asked once connected (again until it says)."""
        if (forced := ri.configured_ros()) is not None:
            self.ros_version = forced
            return
        while True:
            if self.ros is not None and self.ros.is_connected:
                version, why = await ask_ros_version(self.ros, settings.ROBOT_REQUEST_TIMEOUT_S)
                if version is not None:
                    self.ros_version = version
                    ri.use_ros(version)
                    return
                log.warning("standby link: could not find out which ROS the robot runs (%s)", why)
            await asyncio.sleep(1.0)

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
            if self.ros_version == ri.ROS2 and (routed := await self.nav2.publish(request["topic"], msg)):
                return routed
            self._publishers.publish(self.ros, request["topic"], request["msg_type"], msg)
            return {"ok": True}
        timeout = float(request.get("timeout") or settings.ROBOT_REQUEST_TIMEOUT_S)
        return await call_service(self.ros, request["service"], request["service_type"], msg, timeout)

    def _publish_zero(self) -> None:
        if self.ros is None or not self.ros.is_connected:
            raise RuntimeError("standby link: robot offline")
        cmd_vel = ri.topic("cmd_vel", self.ros_version)
        self._publishers.publish(self.ros, cmd_vel.name, cmd_vel.type, ri.ZERO_TWIST)
