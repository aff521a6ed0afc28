"""Helpers for the teleop tests: a drive socket per user, what reached the simulator, how an E-STOP's
steps ended."""

from __future__ import annotations

import asyncio
import time
from typing import Any

from robot import interface as ri
from tests.helpers import DEADLINE_S, async_wait_until, receive_until, ws_communicator


async def drive_socket(user) -> Any:
    """A connected ``/ws/teleop/`` communicator that has read its first lock frame."""
    communicator = ws_communicator(user, "/ws/teleop/")
    connected, _ = await communicator.connect(timeout=10)  # a loaded machine is slow to accept
    assert connected
    frame = await communicator.receive_json_from(timeout=10)
    assert frame["type"] == "lock"
    return communicator


def key(linear: float = 0.0, angular: float = 0.0, **extra: Any) -> dict[str, Any]:
    return {"type": "input", "linear": linear, "angular": angular, **extra}


async def twists(sim) -> list[dict[str, Any]]:
    return await asyncio.to_thread(sim.received, ri.topic("cmd_vel").name)


async def wait_twist(
    sim, predicate, *, after: int = 0, timeout: float = DEADLINE_S, what: str = "a Twist"
) -> dict[str, Any]:
    """The first Twist the simulator received (from index ``after`` on) that matches."""
    found: list[dict[str, Any]] = []

    def check() -> bool:
        got = [t for t in sim.received(ri.topic("cmd_vel").name)[after:] if predicate(t)]
        found[:] = got[:1]
        return bool(got)

    await async_wait_until(check, timeout=timeout, what=what)
    return found[0]


def is_zero(t: dict[str, Any]) -> bool:
    return t["linear"]["x"] == 0 and t["angular"]["z"] == 0


def is_moving(t: dict[str, Any]) -> bool:
    return not is_zero(t)


async def error_frame(communicator) -> dict[str, Any]:
    return await receive_until(communicator, lambda f: f["type"] == "error")


async def lock_frame(communicator, predicate=lambda f: True) -> dict[str, Any]:
    return await receive_until(communicator, lambda f: f["type"] == "lock" and predicate(f))


STILL_TRYING = "(still trying)"


async def settled_steps(timeout: float = 30.0) -> dict[str, dict[str, Any]]:
    """The E-STOP's steps as they ended: on a loaded machine a step can answer after the report (which
    says it is still trying), and is kept with the latch when it ends."""
    from robot.estop.latch import alatch

    deadline = time.monotonic() + timeout
    while True:
        latch = await alatch()
        steps = {s["step"]: s for s in latch.steps}
        if latch.latched and steps and not any(s["detail"].endswith(STILL_TRYING) for s in steps.values()):
            return steps
        assert time.monotonic() < deadline, f"E-STOP steps still running after {timeout} s: {steps}"
        await asyncio.sleep(0.05)
