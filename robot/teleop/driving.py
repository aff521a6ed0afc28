"""Drive-lock services: take, take over and give up the lock, each audited and announced
to every open drive page (in every web process) through one channel group."""

from __future__ import annotations

from typing import Any, Literal, TypedDict

from channels.db import database_sync_to_async
from channels.layers import get_channel_layer

from cyborg_site.roles import is_admin
from robot.commands.audit import audit_record
from robot.commands.pipeline import Busy, arun_command
from robot.estop.latch import ensure_released
from robot.link.bus import EstopEngaged, RobotError, RobotNotResponding
from robot.live.groups import LOCK_GROUP, STATUS_KEY
from robot.live.locks import HeldLock, Holder
from robot.live.state import get_store, status_view
from robot.teleop.lock import get_lock
from robot.teleop.session import publish_cmd_vel
from robot.teleop.twist import STOP


class LockEvent(TypedDict):
    type: Literal["teleop.lock"]
    holder: str | None  # username
    owner: str | None  # the holding connection
    reason: str  # acquire | takeover | release | disconnect | timeout | estop | estop_release


async def announce(holder: Holder | None, reason: str) -> None:
    event: LockEvent = {
        "type": "teleop.lock", "holder": holder.username if holder else None,
        "owner": holder.owner if holder else None, "reason": reason,
    }
    await get_channel_layer().group_send(LOCK_GROUP, event)


async def free_for_the_stop(by: str) -> str:
    """The E-STOP's step: free the drive lock. Every teleop loop's next refresh fails and the
    announcement stops them at once; the latch refuses the lock to anyone until it is released."""
    previous = await get_lock().clear()
    await announce(None, "estop")
    return f"{previous.username} stopped driving" if previous else "nobody was driving"


async def announce_release() -> None:
    await announce(None, "estop_release")


async def lock_acquire(*, user: Any, me: Holder, lock: HeldLock | None = None) -> None:
    """Take the free lock for ``me``; Busy if another connection drives."""
    lock = lock or get_lock()

    async def run() -> str:
        await _refuse_if_not_responding()
        current = await lock.acquire(me)
        if current != me:
            raise Busy(f"{current.username} is driving.")
        await _give_back_if_latched(lock, me)
        await announce(me, "acquire")
        return "drive lock taken"

    await arun_command(user=user, source="websocket", action="teleop.lock", params={}, run=run)


async def lock_takeover(*, user: Any, me: Holder, lock: HeldLock | None = None) -> None:
    """An admin takes the lock from whoever holds it; the robot is stopped first."""
    lock = lock or get_lock()
    previous: Holder | None = None

    async def run() -> str:
        nonlocal previous
        previous = await lock.take(me)
        await _give_back_if_latched(lock, me)
        await announce(me, "takeover")
        if previous is None or previous == me:
            return "drive lock taken (it was free)"
        try:
            await publish_cmd_vel(STOP)
        except RobotError as exc:
            return f"took the drive lock from {previous.username}; zero velocity not sent: {exc.message}"
        return f"took the drive lock from {previous.username}"

    await arun_command(user=user, source="websocket", action="teleop.takeover", params={}, run=run, allowed=is_admin,
                       refusal="Only admins may take over the drive lock.")


async def _refuse_if_not_responding() -> None:
    """A hung robot takes no moves: the lock to make them is not handed out either (the page offers none)."""
    view = status_view((await get_store().aget_many([STATUS_KEY])).get(STATUS_KEY))
    if view["robot_connected"] and not view["responding"]:
        raise RobotNotResponding("Robot not responding: the drive lock is given once it answers again.")


async def _give_back_if_latched(lock: HeldLock, me: Holder) -> None:
    """An E-STOP pressed while we took the lock: its own clear may have run before our take."""
    try:
        await ensure_released()
    except EstopEngaged:
        await lock.release(me)
        raise


async def lock_release(*, user: Any, me: Holder, reason: str, lock: HeldLock | None = None) -> bool:
    """Give up the lock if ``me`` holds it (unlock, disconnect); True if it was held."""
    lock = lock or get_lock()
    if not await lock.release(me):
        return False
    await announce(None, reason)
    await teleop_record(user=user, action="teleop.unlock", params={"reason": reason},
                        outcome=f"drive lock freed ({reason})")
    return True


async def teleop_record(*, user: Any, action: str, outcome: str, ok: bool = True, params: dict | None = None) -> None:
    """Audit a teleop event that is not a command (deadman stop, refused input)."""
    await database_sync_to_async(audit_record)(
        user=user, source="websocket", action=action, params=params or {}, ok=ok, outcome=outcome,
        error_code="" if ok else "refused",
    )
