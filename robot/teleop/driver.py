"""One drive page's connection: the ``/ws/teleop/`` protocol behind a thin consumer.

client → server: {"type": "input", "linear", "angular", "max_linear", "max_angular"} | "release" | "hidden"
| "acquire" | "takeover" (admins) | "unlock"
server → client: {"type": "lock", "holder", "you"} | {"type": "commanded", "linear", "angular"}
| {"type": "error", "message", "code"} | {"type": "estop", "latched", "message", "by", "at"}
| {"type": "notice", "message", "code"} (e.g. an admin took over from this driver)

While the E-STOP is latched every input, lock request and takeover is refused (code "estop"); while
the motors are off every moving input is refused (code "motors_off").

Viewers may connect to see who drives; everything that would move the robot is refused.
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from typing import Any

from django.conf import settings

from robot.commands.motors import MotorsOff, ensure_motors_on
from robot.commands.pipeline import Busy, Forbidden, InvalidCommand
from robot.estop.latch import alatch
from robot.link.bus import EstopEngaged, RobotError
from robot.live.locks import HeldLock, Holder
from robot.supervisor import Tasks
from robot.teleop.driving import LockEvent, announce, lock_acquire, lock_release, lock_takeover, teleop_record
from robot.teleop.lock import get_lock
from robot.teleop.session import NotHolding, TeleopSession
from robot.teleop.twist import Command, InvalidInput, command_from_input

Send = Callable[[dict[str, Any]], Awaitable[None]]


class Driver:
    def __init__(self, *, user: Any, owner: str, can_drive: bool, send: Send, lock: HeldLock | None = None) -> None:
        self.user = user
        self.me = Holder(owner=owner, username=user.get_username())
        self.can_drive = can_drive
        self.send = send
        self.lock = lock or get_lock()
        self.session = TeleopSession(self.me, lock=self.lock, listener=self._on_session)
        self.holding = False
        self._refused: object = None  # who we last told this user is driving (audited once)
        self._expiry: asyncio.Task | None = None
        self._tasks = Tasks()

    async def start(self) -> None:
        holder = await self.lock.holder()
        await self._send_lock(holder.username if holder else None, holder == self.me)
        await self._send_estop(only_latched=True)

    async def handle(self, content: Any) -> None:
        kind = content.get("type") if isinstance(content, dict) else None
        handler = {
            "input": self._input, "release": self._stop, "hidden": self._stop, "acquire": self._acquire,
            "takeover": self._takeover, "unlock": self._unlock,
        }.get(kind)  # type: ignore[arg-type]
        if handler is None:
            await self._error(f"Unknown message type {kind!r}", "invalid")
            return
        try:
            await handler(content)
        except RobotError as exc:
            await self._error(exc.message, exc.code)

    async def close(self) -> None:
        """The socket went away: stop the robot if we moved it, free the lock."""
        self._cancel_expiry()
        await self.session.close()
        if self.holding or await self.lock.holder() == self.me:
            self.holding = False
            await lock_release(user=self.user, me=self.me, reason="disconnect", lock=self.lock)

    async def on_lock_event(self, event: LockEvent) -> None:
        mine = event["owner"] == self.me.owner
        if self.holding and not mine:
            self.session.lost()
            self._cancel_expiry()
            if event["reason"] == "estop":  # the stop published zero for us
                await self.send({"type": "commanded", "linear": 0.0, "angular": 0.0, "reason": "estop"})
        if self.holding and not mine and event["reason"] == "takeover":
            await self.send({"type": "notice", "code": "takeover",
                             "message": f"{event['holder']} took over driving: the robot was stopped."})
        self.holding = mine
        await self._send_lock(event["holder"], mine)
        if event["reason"] in ("estop", "estop_release"):
            await self._send_estop()

    # --- client messages -------------------------------------------------------------

    async def _input(self, content: dict[str, Any]) -> None:
        if not self.can_drive:
            await self._refuse("viewer", Forbidden("Viewers cannot drive (operators and admins can)."))
        try:
            command = command_from_input(content)
        except InvalidInput as exc:
            raise InvalidCommand(str(exc)) from None
        self._cancel_expiry()
        if not self.holding:
            await self._refuse_if_latched()  # the stop is the reason to give, motors off or not
        if not command.is_zero:
            await self._refuse_if_motors_off()
        if not self.holding:
            await self._take_free_lock()
        try:
            await self.session.drive(command)
        except NotHolding:
            self.holding = False
            holder = await self.lock.holder()
            await self._send_lock(holder.username if holder else None, False)
            await self._refuse_if_latched()
            raise
        if command.is_zero:
            self._watch_expiry()

    async def _stop(self, content: dict[str, Any]) -> None:
        await self.session.halt()
        if self.holding:
            self._watch_expiry()

    async def _acquire(self, content: dict[str, Any]) -> None:
        if not self.can_drive:
            raise Forbidden("Viewers cannot drive (operators and admins can).")
        await lock_acquire(user=self.user, me=self.me, lock=self.lock)
        self.holding = True
        self._watch_expiry()

    async def _takeover(self, content: dict[str, Any]) -> None:
        await lock_takeover(user=self.user, me=self.me, lock=self.lock)
        self.holding = True
        self._watch_expiry()

    async def _unlock(self, content: dict[str, Any]) -> None:
        self._cancel_expiry()
        await self.session.halt()
        self.holding = False
        await lock_release(user=self.user, me=self.me, reason="release", lock=self.lock)

    # --- helpers ---------------------------------------------------------------------

    async def _take_free_lock(self) -> None:
        """Driving takes a free lock by itself; a busy one is refused (and audited once per holder)."""
        current = await self.lock.holder()
        if current is not None and current != self.me:
            await self._send_lock(current.username, False)
            await self._refuse(current, Busy(f"{current.username} is driving."))
        await lock_acquire(user=self.user, me=self.me, lock=self.lock)
        self.holding = True

    async def _refuse_if_latched(self) -> None:
        """A held key keeps sending input: refuse it, audited once per E-STOP."""
        latch = await alatch()
        if latch.latched:
            await self._refuse(("estop", latch.at), EstopEngaged(f"{latch.message}; driving is blocked until "
                                                                 "an operator releases it."))

    async def _refuse_if_motors_off(self) -> None:
        """Motors off, a move goes nowhere: stop what this driver sent and say why (audited once)."""
        try:
            await ensure_motors_on("driving")
        except MotorsOff as exc:
            await self.session.halt()
            await self._refuse_if_latched()  # the stop turned them off: it is the reason to give
            await self._refuse("motors_off", exc)

    async def _refuse(self, reason: object, error: RobotError) -> None:
        if self._refused != reason:
            self._refused = reason
            await teleop_record(user=self.user, action="teleop.input", ok=False, outcome=error.message)
        raise error

    async def _on_session(self, kind: str, detail: object) -> None:
        if kind == "commanded" and isinstance(detail, Command):
            await self.send({"type": "commanded", "linear": detail.linear, "angular": detail.angular})
        elif kind == "deadman":
            await self.send({"type": "commanded", "linear": 0.0, "angular": 0.0, "reason": "deadman"})
            await teleop_record(user=self.user, action="teleop.deadman",
                                outcome=f"no input for {self.session.deadman_s:g} s: robot stopped")
            self._watch_expiry()
        elif kind == "lost":
            self.holding = False
            holder = await self.lock.holder()
            await self._send_lock(holder.username if holder else None, False)
        elif kind == "error" and isinstance(detail, RobotError):
            await self._error(detail.message, detail.code)

    def _watch_expiry(self) -> None:
        """Tell every page when an idle driver's lock runs out (nobody else would notice)."""
        self._cancel_expiry()
        self._expiry = self._tasks.start(self._expire_later())

    def _cancel_expiry(self) -> None:
        if self._expiry is not None and self._expiry is not asyncio.current_task():
            self._expiry.cancel()
        self._expiry = None

    async def _expire_later(self) -> None:
        await asyncio.sleep(settings.TELEOP_LOCK_TTL_S + 0.05)
        if self.holding and await self.lock.holder() is None:
            self.holding = False
            await announce(None, "timeout")
            await teleop_record(user=self.user, action="teleop.unlock", params={"reason": "timeout"},
                                outcome="drive lock freed (idle timeout)")

    async def _send_estop(self, *, only_latched: bool = False) -> None:
        latch = await alatch()
        if latch.latched or not only_latched:
            msg = latch.as_msg()
            await self.send({"type": "estop", **{k: msg[k] for k in ("latched", "message", "by", "at", "at_text")}})

    async def _send_lock(self, holder: str | None, you: bool) -> None:
        await self.send({"type": "lock", "holder": holder, "you": you})

    async def _error(self, message: str, code: str) -> None:
        await self.send({"type": "error", "message": message, "code": code})
