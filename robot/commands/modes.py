"""The mode commander: Behaviour, Demo, Manual, Stop.

Two strategies (``settings.MODE_COMMANDER``):

- ``server`` (default): this server performs the commander's sequence itself (events,
  emotion system ON/OFF, the pause), for robots without the ROS commander node. It must
  not also publish ``robot_mode``, or a robot that has the node would run it twice.
- ``robot``: publish the mode string on ``robot_mode`` and let the robot's commander run it.

Either way the server first walks the state machine to suspension (moderoute), because the
commander's sequences fail from inside the behaviour container, and checks the result.

Mode changes are serialised: a second request while one runs is refused with 409 ``Busy``
rather than queued (an operator who clicked Demo then Manual should see that Demo is still
being applied, not have Manual fire half a second later). The lock is a redis-py ``Lock``
(expiring just after the longest sequence), so it holds across web processes. ``perform_mode`` is the raw
work without the lock, role check or audit: the emergency stop composes it and must never
be refused because a mode change is running.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from django.conf import settings

from robot import interface as ri
from robot.commands import moderoute
from robot.commands.pipeline import Busy, Command, arun, gate
from robot.commands.statewatch import Change, StateWatch
from robot.commands.validation import clean_mode
from robot.link import bus
from robot.live import locks
from robot.live.announce import apublish_state
from robot.live.groups import MODE_REQUEST_KEY

# How long one step may take to show up on state_change, and how many steps a change may take
# (the longest way out is sleeping → idle → suspension; the rest is room for states that move
# on by themselves while we walk).
STEP_TIMEOUT_S = 2.0
MAX_STEPS = 8
# How long to wait for the robot's first report when it has said nothing since the link
# (re)connected: its SMACH status repeats about once a second.
SETTLE_S = 1.5
# How often a pause in a mode change looks at the E-STOP latch.
LATCH_POLL_S = 0.03


def sequence_pause_s(mode: ri.Mode) -> float:
    return sum(float(value) for kind, value in ri.COMMANDER_SEQUENCES[mode] if kind == "pause")


def longest_change_s(mode: ri.Mode) -> float:
    return SETTLE_S + sequence_pause_s(mode) + (MAX_STEPS + 1) * STEP_TIMEOUT_S


def state_reached(mode: ri.Mode, state: str) -> bool:
    """Is the state machine in ``state`` where ``mode`` should have taken it?"""
    target = ri.MODE_TARGET_STATE[mode].value
    if target == ri.State.BEHAVIOUR.value:
        return moderoute.in_behaviour(state)
    return state == target


# --- the work --------------------------------------------------------------------------


class ModeStepFailed(bus.RobotError):
    pass


class _Walk:
    """One mode change: the steps taken so far, each checked against state_change."""

    def __init__(self, mode: ri.Mode, watch: StateWatch) -> None:
        self.mode = mode
        self.watch = watch
        self.done: list[str] = []

    def fail(self, what: str, why: str) -> ModeStepFailed:
        return ModeStepFailed(
            f"{self.mode.short.capitalize()} mode not reached: step {len(self.done) + 1} ({what}) failed: {why}; "
            f"the state machine is in {self.watch.state or 'an unknown state'}."
            + (f" Done before it: {', '.join(self.done)}." if self.done else ""))

    async def emotion_system(self, on: bool) -> None:
        await bus.apublish("emotional_controller", {"data": ri.EMOTION_SYSTEM_ON if on else ri.EMOTION_SYSTEM_OFF})
        self.done.append(f"emotion system {ri.EMOTION_SYSTEM_ON if on else ri.EMOTION_SYSTEM_OFF}")

    async def event(self, step: moderoute.Step) -> Change | None:
        """Send the step's event; its state_change, or None if the state moved on by itself meanwhile."""
        await bus.apublish("register_event", {"data": step.event})
        change = await self.watch.wait_for(lambda c: c.get("event") == step.event, STEP_TIMEOUT_S)
        if change is None:
            if step.from_state and self.watch.state != step.from_state:
                return None  # something else moved it (a behaviour finishing): plan again from there
            raise self.fail(step.describe(), f"no state_change for it within {STEP_TIMEOUT_S:g} s (ignored?)")
        self.done.append(f"{step.event} ({change.get('from_system_state')} → {change.get('to_system_state')})")
        return change

    async def to_suspension(self) -> None:
        for _ in range(MAX_STEPS):
            step = moderoute.way_out(self.watch.state)
            if step is None:
                return
            await self.event(step)
        raise self.fail("reach suspension", f"still not there after {MAX_STEPS} steps")

    async def enter(self) -> None:
        step = moderoute.way_in(self.mode)
        if step is None:
            return
        change = await self.event(step)
        if change is None or not state_reached(self.mode, change.get("to_system_state", "")):
            raise self.fail(step.describe(), f"it led to {self.watch.state or 'no state'}")

    async def by_robot_commander(self) -> None:
        await bus.apublish("robot_mode", {"data": self.mode.value})
        what = f"robot_mode '{self.mode.value}' to the robot's commander"
        # The commander's sequence starts with `aborted` (suspension → suspension) and, but for
        # stop, ends with the mode's start event.
        last = ri.MODE_ENTRY[self.mode][1] or ri.Event.ABORTED
        change = await self.watch.wait_for(
            lambda c: c.get("event") == last and state_reached(self.mode, c.get("to_system_state", "")),
            sequence_pause_s(self.mode) + STEP_TIMEOUT_S)
        if change is None:
            raise self.fail(what, f"the state machine did not reach {ri.MODE_TARGET_STATE[self.mode].value} "
                                  f"within {sequence_pause_s(self.mode) + STEP_TIMEOUT_S:g} s")
        self.done.append(what)


async def _pause(seconds: float) -> None:
    """Sleep, ending at once with ``EstopEngaged`` should the E-STOP latch meanwhile: the stop's own
    walk to suspension waits for a change under way to end, and must not wait out its pause."""
    deadline = asyncio.get_running_loop().time() + seconds
    while (left := deadline - asyncio.get_running_loop().time()) > 0:
        await gate().ensure_released()
        await asyncio.sleep(min(LATCH_POLL_S, left))
    await gate().ensure_released()


async def _change(mode: ri.Mode) -> str:
    watch = StateWatch()
    await watch.start(settle_s=SETTLE_S)
    walk = _Walk(mode, watch)
    by_server = settings.MODE_COMMANDER != "robot"
    emotion_on = ri.MODE_ENTRY[mode][0]
    if by_server and not emotion_on:
        await walk.emotion_system(False)  # first, so the behaviour system starts nothing new on the way out
    await walk.to_suspension()
    if by_server:
        if mode is not ri.Mode.STOP:
            await _pause(ri.COMMANDER_PAUSE_S)  # the commander's pause before entering a mode
            if emotion_on:
                await walk.emotion_system(True)
            await walk.enter()
    else:
        await walk.by_robot_commander()
    return f"{mode.short.capitalize()} mode reached ({watch.state}): {', '.join(walk.done) or 'already there'}"


async def perform_mode(mode: ri.Mode, *, requested_by: str = "") -> str:
    """Change to ``mode`` from whatever state the robot is in, with the configured strategy.

    Walks the state machine out of the behaviour container (and any state nested in it) to
    suspension, then into the mode, checking every step on ``state_change``; raises
    ``RobotError`` naming the step that failed."""
    await announce_request(mode, by=requested_by, status="running")
    try:
        outcome = await _change(mode)
    except bus.RobotError as exc:
        await announce_request(mode, by=requested_by, status="failed", error=exc.message)
        raise
    await announce_request(mode, by=requested_by, status="reached")
    return outcome


async def perform_stop(*, requested_by: str = "") -> str:
    """Mode stop for the E-STOP. A mode change under way may have sent its last event just before
    the latch (the link refuses the ones after), and the robot's answer to it can land after this
    walk reached suspension: once that change has ended, walk again from where the robot is."""
    under_way = await locks.is_taken(LOCK)
    outcome = await perform_mode(ri.Mode.STOP, requested_by=requested_by)
    if not under_way:
        return outcome
    deadline = asyncio.get_running_loop().time() + STEP_TIMEOUT_S
    while await locks.is_taken(LOCK) and asyncio.get_running_loop().time() < deadline:
        await asyncio.sleep(0.02)
    return await perform_mode(ri.Mode.STOP, requested_by=requested_by)


def change_mode(mode: ri.Mode | Any, *, user: Any) -> Command:
    """The full command: validation, serialisation (role check and audit by the pipeline)."""

    async def send(chosen: ri.Mode) -> str:
        async with serialised(chosen):
            by = user.get_username() if getattr(user, "is_authenticated", False) else ""
            return await perform_mode(chosen, requested_by=by)

    params = {"mode": mode.short if isinstance(mode, ri.Mode) else mode}
    return Command("mode", params, send, check=lambda: clean_mode(mode))


async def achange_mode(*, user: Any, source: str, mode: ri.Mode | Any) -> str:
    return await arun(change_mode(mode, user=user), user=user, source=source)


# --- requested mode, visible to every open page ------------------------------------------


async def announce_request(mode: ri.Mode, *, by: str, status: str, error: str = "") -> None:
    await apublish_state(MODE_REQUEST_KEY, {
        "mode": mode.short, "value": mode.value, "target_state": ri.MODE_TARGET_STATE[mode].value,
        "by": by, "status": status, "error": error, "strategy": settings.MODE_COMMANDER,
    })


# --- serialisation -----------------------------------------------------------------------

LOCK = "mode-change-lock"


@asynccontextmanager
async def serialised(mode: ri.Mode) -> AsyncIterator[None]:
    """Hold the mode-change lock for the duration, or raise ``Busy``; it expires just after the
    longest a sequence can take, should this process die holding it."""
    try:
        async with locks.exclusive(LOCK, mode.short, ttl_s=longest_change_s(mode) + 1.0):
            yield
    except locks.Taken as taken:
        raise Busy(f"A mode change to {taken.label or 'another mode'} is already in progress; "
                   "try again in a moment.") from None
