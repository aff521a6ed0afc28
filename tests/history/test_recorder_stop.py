"""A stopping recorder, cancelled in the middle of a store write, ends and makes its final flush."""

from __future__ import annotations

import asyncio
import types

from history.recorder import Recorder
from tests.helpers import DEADLINE_S


async def test_a_recorder_cancelled_mid_write_ends_and_flushes():
    rec = Recorder(flush_s=0.05, writer=len)
    writing = asyncio.Event()
    flushes: list[str] = []

    async def nothing(*_: object) -> None:
        return None

    async def publish_watermark(store: object) -> None:
        writing.set()
        await asyncio.sleep(0.2)

    async def flush() -> int:
        flushes.append("flush")
        return 0

    rec.reload, rec.resume_after, rec.publish_watermark, rec.flush = nothing, nothing, publish_watermark, flush
    running = asyncio.ensure_future(rec.run(types.SimpleNamespace(listeners=[], store=None)))
    await asyncio.wait_for(writing.wait(), 2)
    flushed_before = len(flushes)
    running.cancel()
    done, _ = await asyncio.wait({running}, timeout=DEADLINE_S)
    assert done, "the recorder went on recording, its stop lost: the link's stop gave up on it unflushed"
    assert len(flushes) > flushed_before, "no final flush"
