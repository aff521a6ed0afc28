"""The mode commander: Behaviour, Demo, Manual, Stop.

Two strategies (``settings.MODE_COMMANDER``):

- ``server`` (default): this server performs the commander's sequence itself (events,
  emotion system ON/OFF, the pause), for robots without the ROS commander node. It must
  not also publish ``robot_mode``, or a robot that has the node would run it twice.
- ``robot``: publish the mode string on ``robot_mode`` and let the robot's commander run it.

Mode changes are serialised: a second request while one runs is refused with 409 ``Busy``
rather than queued (an operator who clicked Demo then Manual should see that Demo is still
being applied, not have Manual fire half a second later). The lock is in-process in the
embedded default and a Redis key (``SET NX PX``, expiring just after the longest sequence)
when ``REDIS_URL`` is set, so it holds across web processes. ``perform_mode`` is the raw
work without the lock, role check or audit: the emergency stop composes it and must never
be refused because a mode change is running.
"""

from __future__ import annotations

import asyncio
import threading
import time
import uuid
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from channels.layers import get_channel_layer
from django.conf import settings

from robot import bus
from robot import interface as ri
from robot.commanding import Busy, arun_command
from robot.commands.validation import clean_mode
from robot.groups import topic_group
from robot.state import get_store
from robot.teleop.latch import ensure_released

# Latest-state key (server-side, not a ROS topic) holding the last requested mode.
MODE_REQUEST_KEY = "mode_request"
# Top-level states other than behaviour; any other state is in (a leaf of) the behaviour container.
_OUTSIDE_BEHAVIOUR = frozenset(s.value for s in ri.State) - {ri.State.BEHAVIOUR.value, ri.State.IDLE.value}


def sequence_pause_s(mode: ri.Mode) -> float:
    return sum(float(value) for kind, value in ri.COMMANDER_SEQUENCES[mode] if kind == "pause")


def state_reached(mode: ri.Mode, state: str) -> bool:
    """Is the state machine in ``state`` where ``mode`` should have taken it?"""
    target = ri.MODE_TARGET_STATE[mode].value
    if target == ri.State.BEHAVIOUR.value:
        return bool(state) and state not in _OUTSIDE_BEHAVIOUR
    return state == target


# --- the work --------------------------------------------------------------------------


async def _run_sequence(mode: ri.Mode) -> None:
    for kind, value in ri.COMMANDER_SEQUENCES[mode]:
        if kind == "pause":
            await asyncio.sleep(float(value))
        elif kind == "event":
            await bus.apublish("register_event", {"data": str(value)})
        elif kind == "emotion_system":
            switch = ri.EMOTION_SYSTEM_ON if value else ri.EMOTION_SYSTEM_OFF
            await bus.apublish("emotional_controller", {"data": switch})


def _describe(mode: ri.Mode) -> str:
    steps = []
    for kind, value in ri.COMMANDER_SEQUENCES[mode]:
        if kind == "event":
            steps.append(str(value))
        elif kind == "emotion_system":
            steps.append(f"emotion system {ri.EMOTION_SYSTEM_ON if value else ri.EMOTION_SYSTEM_OFF}")
    return ", ".join(steps)


async def perform_mode(mode: ri.Mode, *, requested_by: str = "") -> str:
    """Change to ``mode`` with the configured strategy; raises ``RobotError`` on failure."""
    await announce_request(mode, by=requested_by, status="running")
    try:
        if settings.MODE_COMMANDER == "robot":
            await bus.apublish("robot_mode", {"data": mode.value})
            outcome = f"Asked the robot's commander for {mode.short} mode"
        else:
            await _run_sequence(mode)
            outcome = f"{mode.short.capitalize()} mode: sent {_describe(mode)}"
    except bus.RobotError as exc:
        await announce_request(mode, by=requested_by, status="failed", error=exc.message)
        raise
    await announce_request(mode, by=requested_by, status="sent")
    return outcome


async def achange_mode(*, user: Any, source: str, mode: ri.Mode | Any) -> str:
    """The full command: role check, validation, serialisation, audit."""

    async def run() -> str:
        chosen = clean_mode(mode)
        if chosen is not ri.Mode.STOP:
            await ensure_released()
        async with serialised(chosen):
            by = user.get_username() if getattr(user, "is_authenticated", False) else ""
            outcome = await perform_mode(chosen, requested_by=by)
            if settings.MODE_COMMANDER == "robot":
                # Hold the lock while the robot's commander runs its sequence.
                await asyncio.sleep(sequence_pause_s(chosen))
            return outcome

    params = {"mode": mode.short if isinstance(mode, ri.Mode) else mode}
    return await arun_command(user=user, source=source, action="mode", params=params, run=run)


# --- requested mode, visible to every open page ------------------------------------------


async def announce_request(mode: ri.Mode, *, by: str, status: str, error: str = "") -> None:
    update = {
        "type": "robot.update", "key": MODE_REQUEST_KEY, "topic": "", "msg_type": "", "t": time.time(),
        "msg": {"mode": mode.short, "value": mode.value, "target_state": ri.MODE_TARGET_STATE[mode].value,
                "by": by, "status": status, "error": error, "strategy": settings.MODE_COMMANDER},
    }
    await get_store().aput(MODE_REQUEST_KEY, dict(update))
    await get_channel_layer().group_send(topic_group(MODE_REQUEST_KEY), update)


# --- serialisation -----------------------------------------------------------------------

_local_lock = threading.Lock()  # views run on several loops/threads: not an asyncio.Lock
_local_holder = ""
_RELEASE = "if redis.call('get', KEYS[1]) == ARGV[1] then return redis.call('del', KEYS[1]) else return 0 end"


def _busy(holder: str) -> Busy:
    return Busy(f"A mode change to {holder or 'another mode'} is already in progress; try again in a moment.")


def _lock_key() -> str:
    prefix = settings.CHANNEL_LAYERS["default"].get("CONFIG", {}).get("prefix", "cyborg")
    return f"{prefix}:mode-change-lock"


@asynccontextmanager
async def serialised(mode: ri.Mode) -> AsyncIterator[None]:
    """Hold the mode-change lock for the duration, or raise ``Busy``."""
    if settings.REDIS_URL:
        async with _redis_lock(mode):
            yield
        return
    global _local_holder
    if not _local_lock.acquire(blocking=False):
        raise _busy(_local_holder)
    _local_holder = mode.short
    try:
        yield
    finally:
        _local_holder = ""
        _local_lock.release()


@asynccontextmanager
async def _redis_lock(mode: ri.Mode) -> AsyncIterator[None]:
    import redis.asyncio

    # Expires just after the longest a sequence can take, should this process die holding it.
    ttl_s = sequence_pause_s(mode) + settings.ROBOT_REQUEST_TIMEOUT_S + 1.0
    token = f"{uuid.uuid4().hex}:{mode.short}"
    client = redis.asyncio.Redis.from_url(settings.REDIS_URL)
    try:
        if not await client.set(_lock_key(), token, nx=True, px=int(ttl_s * 1000)):
            held = await client.get(_lock_key())
            raise _busy(held.decode().partition(":")[2] if held else "")
        try:
            yield
        finally:
            await client.eval(_RELEASE, 1, _lock_key(), token)
    finally:
        await client.aclose()
