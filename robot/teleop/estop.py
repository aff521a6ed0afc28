"""The emergency stop: zero velocity (ending any teleop), cancel navigation goals, disable
the motors, mode stop. Every step is tried even when another fails; each result is
reported and the whole is audited."""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

from robot import interface as ri
from robot.bus import RobotError, acall_service
from robot.commanding import arun_command
from robot.commands.modes import perform_mode
from robot.navigation.goals import apublish_action, cancel_message
from robot.teleop.driving import announce
from robot.teleop.lock import get_lock
from robot.teleop.session import publish_cmd_vel
from robot.teleop.twist import STOP

log = logging.getLogger(__name__)

STEP_TIMEOUT_S = 3.0


@dataclass(frozen=True)
class StepResult:
    step: str
    ok: bool
    detail: str


@dataclass(frozen=True)
class EstopReport:
    steps: tuple[StepResult, ...]

    @property
    def ok(self) -> bool:
        return all(s.ok for s in self.steps)

    def summary(self) -> str:
        return "; ".join(f"{s.step}: {'ok' if s.ok else 'FAILED'} ({s.detail})" for s in self.steps)

    def as_dict(self) -> dict[str, Any]:
        return {"ok": self.ok, "steps": [{"step": s.step, "ok": s.ok, "detail": s.detail} for s in self.steps]}


class EstopIncomplete(RobotError):
    status_code = 502
    code = "partial"

    def __init__(self, report: EstopReport) -> None:
        super().__init__("Emergency stop incomplete: " + report.summary())
        self.report = report


async def _zero_velocity(by: str) -> str:
    # Free the lock first: every teleop loop's next refresh fails, and the announcement stops
    # the loops at once, so no driver's Twist follows our zero.
    try:
        previous = await get_lock().clear()
        await announce(None, "estop")
    except Exception:  # the zero Twist matters more than the lock bookkeeping
        log.exception("e-stop could not clear the drive lock")
        previous = None
    await publish_cmd_vel(STOP)
    return f"zero Twist sent; {previous.username} stopped driving" if previous else "zero Twist sent"


async def _cancel_navigation(by: str) -> str:
    # An empty goal id cancels every goal of the server: ours, and any a robot-side node sent.
    for key in ("move_base", "navigation"):
        await apublish_action(key, "cancel", cancel_message())
    return "all navigation goals cancelled"


async def _disable_motors(by: str) -> str:
    await acall_service("disable_motors", timeout=STEP_TIMEOUT_S)
    return "motors disabled"


async def _mode_stop(by: str) -> str:
    # The raw mode change: an e-stop is never refused because a mode change is under way.
    return await perform_mode(ri.Mode.STOP, requested_by=by)


Step = Callable[[str], Awaitable[str]]
STEPS: tuple[tuple[str, Step], ...] = (
    ("zero_velocity", _zero_velocity),
    ("cancel_navigation", _cancel_navigation),
    ("disable_motors", _disable_motors),
    ("mode_stop", _mode_stop),
)


async def _attempt(name: str, step: Step, by: str) -> StepResult:
    try:
        return StepResult(name, True, await asyncio.wait_for(step(by), STEP_TIMEOUT_S + 2))
    except RobotError as exc:
        return StepResult(name, False, exc.message)
    except TimeoutError:
        return StepResult(name, False, "timed out")
    except Exception as exc:  # an e-stop reports every failure rather than stopping at one
        log.exception("e-stop step %s failed", name)
        return StepResult(name, False, f"{type(exc).__name__}: {exc}")


async def estop_steps(*, by: str = "") -> EstopReport:
    """All four steps: the zero Twist first (fastest), then the rest side by side."""
    (first_name, first), rest = STEPS[0], STEPS[1:]
    head = await _attempt(first_name, first, by)
    tail = await asyncio.gather(*(_attempt(name, step, by) for name, step in rest))
    return EstopReport((head, *tail))


async def estop_run(*, user: Any, source: str) -> EstopReport:
    """Role check, the four steps, one audit entry; Forbidden for viewers."""
    report: EstopReport | None = None

    async def run() -> str:
        nonlocal report
        report = await estop_steps(by=user.get_username() if getattr(user, "is_authenticated", False) else "")
        if not report.ok:
            raise EstopIncomplete(report)
        return report.summary()

    try:
        await arun_command(user=user, source=source, action="estop", params={}, run=run)
    except EstopIncomplete as exc:
        return exc.report
    assert report is not None
    return report
