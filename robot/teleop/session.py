"""One driver's teleop loop: publish the commanded Twist at a fixed rate while input is
active, zero at once on release/hide/disconnect, zero after the deadman interval of silence.

The session sends only while its connection holds the drive lock; each publish refreshes
the lock, and a session that lost it (takeover, e-stop) stops without another word.
"""

from __future__ import annotations

import asyncio
import logging
import time
import weakref
from collections.abc import Awaitable, Callable

from django.conf import settings

from robot.link.bus import RobotError, apublish, fresh_press
from robot.live.locks import HeldLock, Holder
from robot.supervisor import supervise
from robot.teleop.twist import STOP, Command, twist

log = logging.getLogger(__name__)

Publisher = Callable[[Command], Awaitable[None]]
# Told about what the session did on its own: ("commanded", cmd) | ("deadman", STOP) | ("lost", STOP)
# | ("error", RobotError).
Listener = Callable[[str, object], Awaitable[None]]


class NotHolding(RobotError):
    status_code = 409
    code = "busy"


async def publish_cmd_vel(command: Command) -> None:
    await apublish("cmd_vel", twist(command))


_sessions: weakref.WeakSet[TeleopSession] = weakref.WeakSet()


async def halt_all() -> int:
    """The process is shutting down: every session that moved the robot sends zero now."""
    results = await asyncio.gather(*(s.halt(for_good=True) for s in list(_sessions)), return_exceptions=True)
    return sum(1 for r in results if r is True)


async def _ignore(kind: str, detail: object) -> None:
    return None


class TeleopSession:
    def __init__(
        self,
        me: Holder,
        *,
        lock: HeldLock,
        publish: Publisher = publish_cmd_vel,
        listener: Listener = _ignore,
        rate_hz: float | None = None,
        deadman_s: float | None = None,
    ) -> None:
        self.me = me
        self.lock = lock
        self._publish_fn = publish
        self._listener = listener
        self.period = 1.0 / (rate_hz or settings.TELEOP_RATE_HZ)
        self.deadman_s = deadman_s or settings.TELEOP_DEADMAN_S
        self.command = STOP
        self.active = False  # input is live: the loop keeps publishing
        self.moving = False  # the last Twist we sent was non-zero
        self._last_input = 0.0
        self._last_publish = 0.0
        self._send = asyncio.Lock()  # one publish at a time, in order: a zero is never overtaken
        self._wake = asyncio.Event()
        self._task: asyncio.Task | None = None
        self.ended = False

    async def drive(self, command: Command) -> Command:
        """New input from the browser; raises NotHolding if this connection lost the lock."""
        _sessions.add(self)
        async with self._send:
            if self.ended:
                raise NotHolding("The server is shutting down: reconnect to drive.")
            if not await self.lock.refresh(self.me):
                raise NotHolding("You do not hold the drive lock.")
            self._last_input = time.monotonic()
            changed = command != self.command or not self.active
            self.command = command
            if command.is_zero:
                self.active = False
                self._wake.set()
                if changed:
                    await self._publish(STOP)
                return command
            if changed:  # a new command goes out now, not at the next tick
                if self.moving:
                    await self._publish(command)
                else:  # a fresh press: it may move a robot whose link was lost (and found) meanwhile
                    with fresh_press():
                        await self._publish(command)
            self.active = True
        if self._task is None or self._task.done():
            self._task = supervise(f"teleop.{self.me.owner}", self._run, transient=True)
        return command

    async def halt(self, *, for_good: bool = False) -> bool:
        """Stop now (release, page hidden, disconnect, e-stop); True if a zero Twist went out.
        ``for_good`` (the process is shutting down): input that still arrives is refused."""
        self.ended = self.ended or for_good
        self.active = False
        self._wake.set()
        async with self._send:
            self.command = STOP
            if not self.moving:
                return False
            await self._publish(STOP)
            return True

    def lost(self) -> None:
        """Someone else holds the lock now: stop sending, without a last word."""
        self.active = False
        self.command = STOP
        self.moving = False
        self._wake.set()

    async def close(self) -> bool:
        sent = await self.halt()
        if self._task is not None:
            self._task.cancel()
            await asyncio.gather(self._task, return_exceptions=True)
        return sent

    async def _publish(self, command: Command) -> None:
        try:
            await self._publish_fn(command)
        except RobotError as exc:
            self.active = False
            await self._listener("error", exc)
            return
        self._last_publish = time.monotonic()
        self.moving = not command.is_zero
        await self._listener("commanded", command)

    async def _run(self) -> None:
        while self.active:
            now = time.monotonic()
            deadline = self._last_input + self.deadman_s
            if now >= deadline:
                await self._deadman()
                return
            wake_at = min(self._last_publish + self.period, deadline)
            try:
                await asyncio.wait_for(self._wake.wait(), max(0.0, wake_at - now))
                self._wake.clear()  # halted, lost or stopped by a zero input: the loop condition decides
                continue
            except TimeoutError:
                pass
            if time.monotonic() >= self._last_input + self.deadman_s:
                continue  # the deadman check at the top of the loop
            async with self._send:
                if not self.active:
                    return
                if time.monotonic() < self._last_publish + self.period:
                    continue  # an input published meanwhile; keep the fixed rate from there
                if not await self.lock.refresh(self.me):
                    self.lost()
                    await self._listener("lost", STOP)
                    return
                await self._publish(self.command)

    async def _deadman(self) -> None:
        async with self._send:
            if not self.active:
                return
            self.active = False
            self.command = STOP
            await self._publish(STOP)
        log.info("teleop deadman: no input from %s for %.2f s", self.me.username, self.deadman_s)
        await self._listener("deadman", STOP)
