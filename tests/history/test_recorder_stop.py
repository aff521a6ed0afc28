"""A stopping recorder ends and makes its final flush even when a store write lost the cancellation
(Python 3.11's wait_for, inside redis-py's writes, can return normally in a task cancelled just then)."""

from __future__ import annotations

import asyncio
import types

from history.recorder import Recorder
from tests.helpers import lose_cancellation


async def test_a_cancelled_recorder_ends_and_flushes_even_if_a_store_write_lost_the_cancellation():
    rec = Recorder(flush_s=0.05, writer=len)
    writing = asyncio.Event()
    flushes: list[str] = []

    async def nothing(*_: object) -> None:
        return None

    async def publish_latest(store: object) -> None:
        writing.set()
        await lose_cancellation()

    async def flush() -> int:
        flushes.append("flush")
        return 0

    rec.reload, rec.resume_after, rec.publish_latest, rec.flush = nothing, nothing, publish_latest, flush
    running = asyncio.ensure_future(rec.run(types.SimpleNamespace(listeners=[], store=None)))
    await asyncio.wait_for(writing.wait(), 2)
    flushed_before = len(flushes)
    running.cancel()
    done, _ = await asyncio.wait({running}, timeout=1)
    assert done, "the recorder went on recording, its stop lost: the link's stop gave up on it unflushed"
    assert len(flushes) > flushed_before, "no final flush"
