"""Host the robot link (and other background services) inside a running event loop.

Used by ``manage.py robotlink`` and, in the embedded default, by the Daphne server
process itself, so both run the same code.
"""

from __future__ import annotations

import asyncio
import functools
import logging
import time
from collections.abc import Awaitable, Callable

from channels.layers import get_channel_layer
from django.conf import settings

from cyborg_site.drain import daphne_reactor
from robot.link import direct
from robot.link.bus import aping_over_queue
from robot.link.connection import RobotLink
from robot.link.lease import Lease
from robot.link.releases import LINK_HOOKS
from robot.live import queues
from robot.live.state import get_store
from robot.supervisor import cancel_and_wait, hold, release, running, spawn, supervise

log = logging.getLogger(__name__)

PROBE_INTERVAL_S = 1.0
PROBE_TIMEOUT_S = 1.0

# Other apps add background loops that must run where the link runs (e.g. history's recorder, and pruning
# in the embedded default). Each gets the link and runs until cancelled.
BackgroundService = Callable[[RobotLink], Awaitable[None]]
_background: list[tuple[str, BackgroundService, bool]] = []


def register_background(name: str, service: BackgroundService, *, embedded_only: bool = False) -> None:
    if all(existing != name for existing, _, _ in _background):
        _background.append((name, service, embedded_only))


async def start_link(
    *, embedded: bool, background: bool = True, lease: Lease | None = None
) -> tuple[RobotLink, list[asyncio.Task]]:
    link = RobotLink(
        settings.ROSBRIDGE_URL,
        store=get_store(),
        layer=get_channel_layer(),
        max_backoff_s=settings.ROBOT_LINK_MAX_BACKOFF_S,
        service_timeout_s=settings.ROBOT_REQUEST_TIMEOUT_S,
        request_queue=queues.requests_key(),
        guard_settings={"rate_hz": settings.TELEOP_RATE_HZ, "hold_s": settings.ESTOP_HOLD_S,
                        "deadman_s": settings.TELEOP_LINK_DEADMAN_S},
        lease=lease,
    )
    try:
        await link.start()
    except BaseException:
        await link.stop()  # what it had started (a rosbridge connection, its loops) goes with it
        raise
    hold(link)
    tasks = [supervise("link.command-path", functools.partial(probe_command_path, link))]
    if not embedded and direct.enabled():
        tasks.append(supervise("link.direct", functools.partial(direct.serve, link.requests.answer)))
    tasks += [
        supervise(f"background.{name}", functools.partial(service, link))
        for name, service, embedded_only in _background
        if background and (embedded or not embedded_only)
    ]
    log.info("robot link started for %s (%s)", settings.ROSBRIDGE_URL, "embedded" if embedded else "standalone")
    return link, tasks


async def stop_link(link: RobotLink, tasks: list[asyncio.Task], *, timeout: float = 4.0) -> None:
    """Stop the background services first and let them finish (the recorder flushes), then the link."""
    started = time.monotonic()
    await cancel_and_wait(tasks, timeout)
    services_done = time.monotonic()
    await link.stop()
    log.info("robot link stopped: background services in %.2f s, then the link in %.2f s",
             services_done - started, time.monotonic() - services_done)
    release(link)


async def probe_command_path(link: RobotLink) -> None:
    """Ping the link over the request channel every web process uses, and say what it found
    in the link's status: a dead request loop or channel layer shows as "command path down"."""
    while True:
        await link.upkeep.set_command_path(await aping_over_queue(PROBE_TIMEOUT_S))
        await asyncio.sleep(PROBE_INTERVAL_S)


def autostart_in_daphne(*, halt_drivers: Callable[[], Awaitable[int]]) -> None:
    """In the Daphne server: stop the robot before exiting (SIGTERM: ``halt_drivers`` sends every
    driver's zero, then the link stops) and, in the embedded default, start the link once the reactor runs."""
    reactor = daphne_reactor()
    if reactor is None:
        return
    reactor.addSystemEventTrigger("before", "shutdown", _stop_robot_before_exit, halt_drivers)
    if settings.EMBEDDED and settings.ROBOT_LINK_EMBEDDED:
        LINK_HOOKS.refuse_others()
        reactor.callWhenRunning(lambda: spawn(start_link(embedded=True)))


def _stop_robot_before_exit(halt_drivers: Callable[[], Awaitable[int]]) -> object:
    from twisted.internet.defer import Deferred

    async def stop() -> None:
        try:
            stopped = await asyncio.wait_for(halt_drivers(), 2)
            if stopped:
                log.warning("shutting down: sent zero for %d driver(s)", stopped)
        except Exception:
            log.exception("shutting down: could not stop every driver")
        if (link := running(RobotLink)) is not None:
            await link.stop()  # the link's own zero if the robot may be moving

    return Deferred.fromFuture(spawn(stop()))
