"""Liveness, not just connection: is the robot still talking?

A frozen robot (its process stopped, its machine hung) keeps the TCP connection open, so the link
stays "connected". The link therefore also watches what it hears: every topic message counts, and a
cheap rosapi call (``/rosapi/get_time``) every ``PROBE_EVERY_S`` answers for a robot whose topics are
quiet. Heard of nothing for ``settings.ROBOT_HANG_S`` (default 2 s), the robot is "not responding":
the link's status says so at once (every page's pill), and commands that move or change the robot
are refused with that reason (``robot.link.bus``) until it answers again.

A wedged socket is another thing: rosbridge 2.x by default handles a client's next frame only after
its open service call is answered, so one call that is never answered leaves the socket sending topic
messages but taking nothing in. Probes that go unanswered ``WEDGED_PROBES`` times in a row while
messages still arrive mean that: the link drops the connection and dials again.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Awaitable, Callable

from django.conf import settings

from robot import interface as ri
from robot.link.dial import Dial
from robot.link.rosclient import call_service
from robot.supervisor import spawn

log = logging.getLogger(__name__)

CHECK_EVERY_S = 0.2
PROBE_EVERY_S = 0.5
WEDGED_PROBES = 3


def hang_s() -> float:
    return float(settings.ROBOT_HANG_S)


def judge(*, connected: bool, heard_at: float, now: float, hang: float) -> bool:
    """Whether a robot heard of last at ``heard_at`` is responding (an unconnected one is simply offline)."""
    return not connected or now - heard_at < hang


async def _probe(link: Dial) -> bool:
    """Whether the probe went unanswered (a failed call is an answer: rosapi may be gone)."""
    if link.ros is None:
        return False
    service = ri.service("rosapi_get_time")
    reply = await call_service(link.ros, service.name, service.type, {}, hang_s())
    if reply.get("ok"):
        link.heard_at = max(link.heard_at, time.time())
    return reply.get("error_code") == "timeout"


async def watch_liveness(link: Dial, changed: Callable[[], Awaitable[None]]) -> None:
    probe: asyncio.Task | None = None
    probed_at = 0.0
    unanswered = 0
    try:
        while not link.stopped:
            await asyncio.sleep(CHECK_EVERY_S)
            now = time.time()
            if probe is not None and probe.done() and not probe.cancelled():
                unanswered = unanswered + 1 if probe.exception() is None and probe.result() else 0
                probe = None
                if unanswered >= WEDGED_PROBES and link.connected and link.responding:
                    log.error("the robot's rosbridge takes nothing in on this connection (%d probes unanswered "
                              "while its messages arrive): reconnecting", unanswered)
                    unanswered = 0
                    link.reconnect()
            if link.connected and (probe is None or probe.done()) and now - probed_at >= PROBE_EVERY_S:
                probed_at = now
                probe = spawn(_probe(link))
            responding = judge(connected=link.connected, heard_at=link.heard_at, now=now, hang=hang_s())
            if responding != link.responding:
                link.responding = responding
                if responding:
                    log.warning("the robot answers again at %s", link.url)
                else:
                    log.error("the robot at %s is not responding: nothing heard for %.1f s", link.url,
                              now - link.heard_at)
                await changed()
    finally:
        if probe is not None:
            probe.cancel()
