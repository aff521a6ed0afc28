"""The emergency stop: latch it, zero velocity (ending any teleop), cancel navigation goals,
disable the motors, mode stop. Every step is tried even when another fails; each result is
reported, kept with the latch for every page to see, and the whole is audited. The latch
holds until an operator releases it (``estop_release``)."""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Any

from robot.commands.modes import perform_stop
from robot.commands.pipeline import Command, InvalidCommand, arun
from robot.estop.latch import Latch, aengage, alatch, arecord_steps, arelease
from robot.link.bus import RobotError, acall_service, arequest, emergency
from robot.supervisor import spawn

log = logging.getLogger(__name__)

STEP_TIMEOUT_S = 3.0
ATTEMPT_TIMEOUT_S = STEP_TIMEOUT_S + 2  # a step that outlives its own time-outs is given up on
ANSWER_S = 0.6  # the answer says what was done by then; a step still running goes on
RECORD_S = 0.1  # and keeping the steps with the latch may take this much more (the audit entry 0.2 s)


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
    # The link publishes zero now and for a short hold, and refuses motion until released.
    reply = await arequest("estop", timeout=STEP_TIMEOUT_S, by=by, at=time.time())
    if reply.get("standby"):
        return "zero Twist sent and held by the standby link (the active one did not answer)"
    return "zero Twist sent and held"


async def _disable_motors(by: str) -> str:
    await acall_service("disable_motors", timeout=STEP_TIMEOUT_S)
    return "motors disabled"


Step = Callable[[str], Awaitable[str]]  # given who pressed, what it did (or raises)
# Every step of the stop, in the order reports list them (the latch comes first, see estop_steps). The
# features' own steps (drive lock, talk, navigation) are theirs: robot.apps registers them.
ORDER = ("zero_velocity", "drive_lock", "talk", "cancel_navigation", "disable_motors", "mode_stop")
STEPS: tuple[tuple[str, Step], ...] = (
    ("zero_velocity", _zero_velocity),
    ("disable_motors", _disable_motors),
    # The raw mode change: an e-stop is never refused because a mode change is under way.
    ("mode_stop", lambda by: perform_stop(requested_by=by)),
)
_released: list[Callable[[], Awaitable[None]]] = []


def register_step(name: str, step: Step) -> None:
    """A feature's own part of the stop, kept in its place in ``ORDER``."""
    global STEPS
    if name not in ORDER:
        raise LookupError(f"{name!r} is not a step of the E-STOP (robot.estop.stop.ORDER)")
    steps = {**dict(STEPS), name: step}
    STEPS = tuple((key, steps[key]) for key in ORDER if key in steps)


def on_release(announce: Callable[[], Awaitable[None]]) -> None:
    """A feature that must hear the release at once (the drivers' sockets)."""
    if announce not in _released:
        _released.append(announce)


def missing_steps() -> list[str]:
    return [name for name in ORDER if name not in dict(STEPS)]


async def _attempt(name: str, step: Step, by: str) -> StepResult:
    try:
        return StepResult(name, True, await asyncio.wait_for(step(by), ATTEMPT_TIMEOUT_S))
    except RobotError as exc:
        return StepResult(name, False, exc.message)
    except TimeoutError:
        return StepResult(name, False, "timed out")
    except Exception as exc:  # an e-stop reports every failure rather than stopping at one
        log.exception("e-stop step %s failed", name)
        return StepResult(name, False, f"{type(exc).__name__}: {exc}")


class _KeptSteps:
    """The steps as kept with the latch. A step that answers after the report is logged and kept in its
    place, so every page shows how it ended; one write at a time, so the newest is the one that stays."""

    def __init__(self, steps: list[dict[str, Any]], engaged: list[Latch]) -> None:
        self.steps = [dict(s) for s in steps]
        self.engaged = engaged
        self.lock = asyncio.Lock()

    async def keep(self) -> Latch:
        async with self.lock:
            return await arecord_steps(self.engaged[0], [dict(s) for s in self.steps])

    def late(self, task: asyncio.Task) -> None:
        if task.cancelled():
            return
        result: StepResult = task.result()
        log.warning("e-stop step %s finished after the answer: %s (%s)", result.step,
                    "ok" if result.ok else "FAILED", result.detail)
        for entry in self.steps:
            if entry["step"] == result.step:
                entry.update(ok=result.ok, detail=f"{result.detail} (after the answer)")
        if self.engaged:
            spawn(self.keep())


async def estop_steps(*, by: str = "") -> tuple[EstopReport, Latch]:
    """Every step side by side, the zero Twist first (it also latches the link); the report within
    ``ANSWER_S``, a step still running then reported as such (it goes on, and keeps its end). With
    the report, the latch as it now stands: from the shared store, or, if that could not be
    written, as the link holds it."""
    started = time.monotonic()
    pressed = time.time()
    engaged: list[Latch] = []

    async def latch(by: str) -> str:
        engaged.append(await aengage(by=by))
        return engaged[0].message

    steps: tuple[tuple[str, Step], ...] = (STEPS[0], ("latch", latch), *STEPS[1:])
    with emergency():  # the steps' requests pass the link's latch, by the direct path where there is one
        tasks = [spawn(_attempt(name, step, by), awaited=True) for name, step in steps]
    done, _ = await asyncio.wait(tasks, timeout=ANSWER_S)
    trying = f"no answer within {ANSWER_S:g} s (still trying)"
    results = [task.result() if task in done else StepResult(name, False, trying)
               for task, (name, _) in zip(tasks, steps, strict=True)]
    zero, stored = results[0], results[1]
    if not stored.ok and zero.ok:
        results[1] = StepResult("latch", False, f"not in the shared store ({stored.detail}); the robot link holds "
                                "it and writes it there when the store answers again")
    report = EstopReport((results[1], zero, *results[2:]))
    done_steps = report.as_dict()["steps"]
    kept = _KeptSteps(done_steps, engaged)
    for task in tasks:
        if task not in done:
            task.add_done_callback(kept.late)
    if engaged:
        try:
            left = max(0.05, ANSWER_S + RECORD_S - (time.monotonic() - started))
            return report, await asyncio.wait_for(kept.keep(), left)
        except Exception:
            log.warning("could not keep the e-stop's step results with the latch", exc_info=True)
        return report, Latch(latched=True, by=engaged[0].by, at=engaged[0].at, steps=done_steps)
    return report, Latch(latched=zero.ok, by=by, at=pressed, steps=done_steps)


def _username(user: Any) -> str:
    return user.get_username() if getattr(user, "is_authenticated", False) else ""


def estop_command(user: Any) -> Command:
    """The stop as one command: role check, latch and steps, one audit entry.

    ``send`` leaves the report and the latch as it then stands in ``result`` (``report``,
    ``latch``), so a caller needs no second trip to the event loop to show them."""

    async def send(_: Any) -> str:
        report, latch = await estop_steps(by=_username(user))
        command.result["report"], command.result["latch"] = report, latch
        if not report.ok:
            raise EstopIncomplete(report)
        return report.summary()

    command = Command("estop", {}, send)
    return command


def release_command(user: Any, confirm: Any) -> Command:
    """An operator's explicit, confirmed release: motion commands are accepted again (the
    motors stay off until someone turns them on). The released latch is left in ``result["latch"]``."""

    async def send(_: Any) -> str:
        if confirm is not True:
            raise InvalidCommand("Confirm the release: send confirm=true.", field="confirm")
        current = await alatch()
        command.result["latch"] = await arelease(by=_username(user))
        try:
            await arequest("estop_release", timeout=STEP_TIMEOUT_S)
        except RobotError as exc:
            # The link reads the latch from the shared store every few seconds and follows.
            log.warning("the link did not take the e-stop release at once: %s", exc.message)
        for announce in _released:
            await announce()
        if not current.latched:
            return "E-STOP was not engaged"
        return f"E-STOP released ({current.message})"

    command = Command("estop.release", {"confirm": confirm}, send)
    return command


def estop_outcome(command: Command) -> EstopReport:
    """The report of a stop that ran (a failed step is in the report, not an exception)."""
    report = command.result["report"]
    assert isinstance(report, EstopReport)
    return report


async def estop_run(*, user: Any, source: str) -> EstopReport:
    """The stop from async code (Forbidden for viewers); the report either way."""
    command = estop_command(user)
    try:
        await arun(command, user=user, source=source)
    except EstopIncomplete:
        pass
    return estop_outcome(command)


async def estop_release(*, user: Any, source: str, confirm: Any) -> Latch:
    """The release from async code; the latch as released."""
    command = release_command(user, confirm)
    await arun(command, user=user, source=source)
    latch = command.result["latch"]
    assert isinstance(latch, Latch)
    return latch
