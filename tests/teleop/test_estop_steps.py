"""The E-STOP tries every step whatever the others do, reports each, and is audited once: a
step that hangs or fails in a way nobody planned for, a robot that is not there, a release the
link does not hear at once."""

from __future__ import annotations

import asyncio

import pytest

from robot.estop import stop as estop
from robot.models import AuditEntry
from tests.teleop.support import settled_steps

pytestmark = pytest.mark.django_db(transaction=True)


async def test_a_step_that_hangs_or_breaks_is_reported_and_every_other_step_still_runs(operator, monkeypatch):
    ran: list[str] = []

    def step(name: str, outcome: str | Exception | None):
        async def run(by: str) -> str:
            ran.append(name)
            if outcome is None:
                await asyncio.sleep(60)
            if isinstance(outcome, Exception):
                raise outcome
            return f"{outcome} for {by}"

        return name, run

    monkeypatch.setattr(estop, "ATTEMPT_TIMEOUT_S", 0.2)
    monkeypatch.setattr(estop, "STEPS", (step("zero_velocity", "zero sent"), step("drive_lock", None),
                                         step("talk", KeyError("speaker")), step("mode_stop", "stopped")))
    report = await estop.estop_run(user=operator, source="page")
    assert sorted(ran) == ["drive_lock", "mode_stop", "talk", "zero_velocity"]
    assert [(s.step, s.ok, s.detail) for s in report.steps] == [
        ("latch", True, report.steps[0].detail), ("zero_velocity", True, "zero sent for otto"),
        ("drive_lock", False, "timed out"), ("talk", False, "KeyError: 'speaker'"),
        ("mode_stop", True, "stopped for otto"),
    ]
    entry = await AuditEntry.objects.aget(action="estop")
    assert (entry.ok, entry.error_code) == (False, "partial") and "drive_lock: FAILED (timed out)" in entry.outcome


async def test_with_no_robot_it_latches_says_what_failed_and_the_release_still_clears_it(operator):
    from robot.estop.latch import alatch

    report = await estop.estop_run(user=operator, source="api")  # no link in this process, no robot
    assert not report.ok
    by_step = await settled_steps()  # a loaded machine can answer a step after the report
    assert by_step["latch"]["ok"] and by_step["drive_lock"]["ok"]
    assert not by_step["zero_velocity"]["ok"] and by_step["zero_velocity"]["detail"].startswith("Robot offline")
    assert (await alatch()).latched
    # The link does not hear the release (there is none): the store is released and the link follows it.
    latch = await estop.estop_release(user=operator, source="api", confirm=True)
    assert not latch.latched and latch.released_by == "otto" and not (await alatch()).latched
    outcomes = [(e.action, e.ok) async for e in AuditEntry.objects.order_by("id")]
    assert outcomes == [("estop", False), ("estop.release", True)]


async def test_a_step_that_answers_after_the_report_is_kept_with_the_latch(operator, monkeypatch):
    async def slow(by: str) -> str:
        await asyncio.sleep(estop.ANSWER_S + 0.3)
        return "motors disabled"

    async def fails_late(by: str) -> str:
        await asyncio.sleep(estop.ANSWER_S + 0.1)
        raise estop.RobotError("Robot offline")

    async def quick(by: str) -> str:
        return "done"

    monkeypatch.setattr(estop, "STEPS", (("zero_velocity", quick), ("drive_lock", fails_late),
                                         ("disable_motors", slow)))
    report = await estop.estop_run(user=operator, source="page")
    late = {s.step: s for s in report.steps if not s.ok}
    assert set(late) == {"drive_lock", "disable_motors"}
    assert all(s.detail.endswith("(still trying)") for s in late.values())

    steps = await settled_steps()
    assert steps["zero_velocity"]["ok"]
    assert (steps["disable_motors"]["ok"], steps["disable_motors"]["detail"]) == (
        True, "motors disabled (after the answer)")
    assert (steps["drive_lock"]["ok"], steps["drive_lock"]["detail"]) == (False, "Robot offline (after the answer)")
