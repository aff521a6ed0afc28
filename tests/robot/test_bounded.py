"""Bounded waits: a task that ignores its cancellation cannot hold its caller, as ``wait_for`` lets it."""

from __future__ import annotations

import asyncio
import logging
import time

import pytest

from robot.bounded import cancel_within, within


async def _stubborn(release: asyncio.Event) -> None:
    """Swallows every cancellation (as a library that turns it into an error of its own and retries)."""
    while not release.is_set():
        try:
            await release.wait()
        except asyncio.CancelledError:
            continue


async def test_wait_for_is_held_by_a_task_that_ignores_cancellation_and_within_is_not():
    release = asyncio.Event()
    held = asyncio.ensure_future(asyncio.wait_for(_stubborn(release), 0.05))
    await asyncio.sleep(0.3)
    assert not held.done(), "wait_for returned: the stubborn stand-in does not show the hazard"

    started = time.monotonic()
    with pytest.raises(TimeoutError):
        await within(_stubborn(release), 0.05)
    assert time.monotonic() - started < 1
    release.set()
    await held


async def test_within_gives_the_result_or_the_error():
    async def value() -> int:
        return 7

    async def fails() -> None:
        raise ValueError("no")

    assert await within(value(), 1) == 7
    with pytest.raises(ValueError, match="no"):
        await within(fails(), 1)


async def test_a_cancelled_caller_cancels_what_it_waited_for():
    inner_cancelled = asyncio.Event()

    async def inner() -> None:
        try:
            await asyncio.sleep(10)
        except asyncio.CancelledError:
            inner_cancelled.set()
            raise

    caller = asyncio.ensure_future(within(inner(), 5))
    await asyncio.sleep(0.05)
    caller.cancel()
    with pytest.raises(asyncio.CancelledError):
        await caller
    await asyncio.wait_for(inner_cancelled.wait(), 1)


async def test_cancel_within_names_a_task_that_did_not_end_and_goes_on(caplog):
    release = asyncio.Event()
    stubborn = asyncio.ensure_future(_stubborn(release))
    polite = asyncio.ensure_future(asyncio.sleep(10))
    await asyncio.sleep(0)
    with caplog.at_level(logging.WARNING, logger="robot.bounded"):
        pending = await cancel_within([stubborn, polite], 0.1)
    assert pending == {stubborn}
    assert polite.cancelled()
    assert "1 task(s) did not end within 0.1 s" in caplog.text
    assert "_stubborn" in caplog.text, "the log says where the task is"
    release.set()
    await stubborn


async def test_the_links_wait_for_its_lease_or_a_stop_ends_when_told_to_stop_whatever_the_lease_does():
    from robot.management.commands.robotlink import _first

    release = asyncio.Event()
    stop = asyncio.Event()
    stop.set()
    started = time.monotonic()
    assert await _first(_stubborn(release), stop.wait()) is False
    assert time.monotonic() - started < 3
    release.set()
    await asyncio.sleep(0.01)  # the abandoned task ends
