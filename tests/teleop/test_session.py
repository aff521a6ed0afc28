"""A driver's session on its own (a drive lock in memory, a recording publisher): a process that
shuts down sends zero for every driver that moved the robot, a publish that fails ends the
stream with the reason, and a lock lost between ticks stops it without a last word."""

from __future__ import annotations

import asyncio

import pytest

from robot.link.bus import RobotOffline
from robot.live.locks import HeldLock, Holder, held_lock
from robot.teleop.session import NotHolding, TeleopSession, halt_all
from robot.teleop.twist import Command
from tests.helpers import async_wait_until

FORWARD = Command(linear=0.3, angular=0.0)


def session(name: str, sent: list[Command], told: list[tuple[str, object]] | None = None,
            fail: bool = False) -> tuple[TeleopSession, HeldLock]:
    async def publish(command: Command) -> None:
        if fail:
            raise RobotOffline("Robot offline: no connection")
        sent.append(command)

    async def listener(kind: str, detail: object) -> None:
        if told is not None:
            told.append((kind, detail))

    lock = held_lock(f"test-drive-lock-{name}", ttl_s=5)
    return TeleopSession(Holder(owner=name, username=name), lock=lock, publish=publish, listener=listener,
                         rate_hz=20, deadman_s=5), lock


async def test_a_shutting_down_process_sends_zero_for_every_driver_that_moved():
    moving, stopped, idle = [], [], []
    drivers = [session("moving", moving), session("stopped", stopped), session("idle", idle)]
    for each, lock in drivers:
        await lock.acquire(each.me)
    await drivers[0][0].drive(FORWARD)
    await drivers[1][0].drive(FORWARD)
    await drivers[1][0].drive(Command())  # let go: already stopped
    try:
        assert await halt_all() >= 1  # (a session another test left moving would count too)
        assert moving[0] == FORWARD and moving[-1].is_zero
        assert stopped[-1].is_zero and len([c for c in stopped if c.is_zero]) == 1  # no second zero
        assert idle == []
        # Input that still arrives while the process drains is refused: the zero stays the last word.
        with pytest.raises(NotHolding):
            await drivers[0][0].drive(FORWARD)
        assert moving[-1].is_zero
    finally:
        for each, _ in drivers:
            await each.close()


async def test_a_failed_publish_ends_the_stream_with_its_reason():
    told: list[tuple[str, object]] = []
    driver, lock = session("otto", [], told, fail=True)
    await lock.acquire(driver.me)
    await driver.drive(FORWARD)
    assert [(kind, str(detail)) for kind, detail in told if kind == "error"] == [
        ("error", "Robot offline: no connection")]
    await async_wait_until(lambda: not driver.active, timeout=5, what="the stream to end")
    await driver.close()


async def test_a_lock_lost_between_ticks_stops_the_stream_without_a_last_word():
    sent: list[Command] = []
    told: list[tuple[str, object]] = []
    driver, lock = session("otto", sent, told)
    await lock.acquire(driver.me)
    await driver.drive(FORWARD)
    await lock.take(Holder(owner="admin", username="ada"))  # an admin took over
    await async_wait_until(lambda: any(kind == "lost" for kind, _ in told), timeout=5, what="the loss noticed")
    count = len(sent)
    await asyncio.sleep(0.2)  # four ticks
    assert len(sent) == count and all(c == FORWARD for c in sent)  # the new holder decides what comes next
    assert not driver.active
    await driver.close()
