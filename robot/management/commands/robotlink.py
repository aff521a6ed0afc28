import asyncio
import faulthandler
import logging
import os
import signal
import socket
from collections.abc import Coroutine
from typing import Any

from django.conf import settings
from django.core.management.base import BaseCommand

from robot.link import direct
from robot.link.hosting import start_link, stop_link
from robot.link.lease import Lease
from robot.link.releases import LINK_HOOKS
from robot.link.standby import StandbyStop
from robot.live.state import redis_key
from robot.supervisor import cancel_and_wait, spawn, supervise

LEASE_KEY = "link-lease"
RETRY_AFTER_FAILURE_S = 1.0
log = logging.getLogger(__name__)


class Command(BaseCommand):
    help = ("Run the robot link: the one rosbridge connection, fan-out to browsers and command relay. "
            "With REDIS_URL, several may run: they share a lease and only its holder connects.")

    def handle(self, *args: Any, **options: Any) -> None:
        LINK_HOOKS.refuse_others()
        asyncio.run(self._run())
        self._say("Robot link stopped.")

    def _say(self, line: str) -> None:
        self.stdout.write(line)
        self.stdout.flush()  # a log file is block-buffered: a line must be there even if the process is killed

    def _stop_requested(self, stop: asyncio.Event) -> None:
        if not stop.is_set():
            _exit_unless_done_within(settings.ROBOT_LINK_STOP_DEADLINE_S)
            stop.set()

    async def _run(self) -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, self._stop_requested, stop)
        if settings.EMBEDDED:  # its own private Redis: no other link shares a lease with it
            link, tasks = await start_link(embedded=False)
            self._say(f"Robot link running for {link.dial.url}; Ctrl-C to stop.")
            await stop.wait()
            await stop_link(link, tasks)
        else:
            await self._run_leased(stop)

    async def _run_leased(self, stop: asyncio.Event) -> None:
        """Standby until this process holds the lease, active while it does, standby again if it loses
        it, or after a failure (logged; its link stopped, the lease released)."""
        name = settings.ROBOT_LINK_NAME or f"{socket.gethostname()}-{os.getpid()}"
        lease = Lease(settings.REDIS_URL, redis_key(LEASE_KEY), holder=name, ttl_s=settings.ROBOT_LINK_LEASE_S)
        try:
            while not stop.is_set():
                self._say(f"Robot link {name}: standby, waiting for the lease.")
                try:
                    if not await _first(_standing_by(lease), stop.wait()):
                        break
                    await self._hold(lease, stop, name)
                except Exception:
                    log.exception("robot link %s failed; standby again", name)
                    await lease.release()
                    await _first(asyncio.sleep(RETRY_AFTER_FAILURE_S), stop.wait())
        finally:
            await lease.release()
            await lease.close()

    async def _hold(self, lease: Lease, stop: asyncio.Event, name: str) -> None:
        """Active until the lease is lost, a stop is asked for or something fails; then the link stops."""
        link, tasks = await start_link(embedded=False, lease=lease)
        self._say(f"Robot link {name}: active for {link.dial.url}; Ctrl-C to stop.")
        renewing: asyncio.Future | None = None
        try:
            await _first(lease.hold(), stop.wait())
            if lease.held:
                # A clean stop: still the holder (renewing) while the link zeroes the robot and flushes.
                renewing = spawn(lease.hold())
            # Otherwise lost: the link publishes nothing more (fencing).
        finally:
            try:
                await stop_link(link, tasks)
            finally:
                if renewing is not None:
                    await cancel_and_wait([renewing], 1)
                    await lease.release()


async def _standing_by(lease: Lease) -> None:
    """Wait for the lease; meanwhile, with the direct path set up, ready to stop the robot (robot.link.standby)."""
    if not direct.enabled():
        return await lease.acquire()
    stopper = supervise("link.standby-stop", StandbyStop(settings.ROSBRIDGE_URL).run)
    try:
        await lease.acquire()
    finally:
        await cancel_and_wait([stopper], 3)


def _exit_unless_done_within(seconds: float) -> None:
    """Past ``seconds``: every thread's stack to stderr (faulthandler), then exit 1. The stop's waits are
    bounded but can add up past the deadline (Redis frozen during the hand-over), and no timeout in the
    loop ends a call that blocks it or a hung worker thread (a rosbridge close, a database write) that
    the interpreter waits for at exit; a process manager would kill it later, without a word. So it is
    never cancelled: the stop is over only when the process has exited."""
    log.info("robot link: stop requested; exiting within %g s (past that, a traceback of every thread "
             "follows on stderr)", seconds)
    faulthandler.dump_traceback_later(seconds, exit=True)


async def _first(main: Coroutine[Any, Any, Any], stop: Coroutine[Any, Any, Any]) -> bool:
    """Run ``main`` until it returns or ``stop`` does; True if ``main`` finished first. A stop ends only
    such waits: cancelling the whole command could cut short a stop of the link already under way."""
    main_task, stop_task = spawn(main, awaited=True), spawn(stop)
    done, pending = await asyncio.wait({main_task, stop_task}, return_when=asyncio.FIRST_COMPLETED)
    await cancel_and_wait(pending, 2)
    if main_task in done:
        main_task.result()  # its error, if it failed, is the caller's
        return True
    return False
