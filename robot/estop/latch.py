"""The E-STOP latch: once engaged it holds, in every process, until an operator releases it.

The latch is one key of the shared latest-state store (in-process in the embedded default,
Redis when scaled), so every web process and the link see the same answer, and pages get
it on the live socket like any other key. While it is engaged, everything that could make
the robot move is refused with ``EstopEngaged`` (409).
"""

from __future__ import annotations

import time
from typing import Any

from robot.link.bus import EstopEngaged
from robot.live.announce import apublish_state
from robot.live.groups import LATCH_KEY
from robot.live.latchstate import Latch
from robot.live.state import get_store


async def alatch() -> Latch:
    entry = (await get_store().aget_many([LATCH_KEY])).get(LATCH_KEY)
    return Latch.from_msg(entry.get("msg") if entry else None)


def latch() -> Latch:
    """The latch from synchronous code (page rendering)."""
    entry = get_store().get_all().get(LATCH_KEY)
    return Latch.from_msg(entry.get("msg") if entry else None)


async def ensure_released() -> None:
    """Raise ``EstopEngaged`` while the E-STOP is latched (call before anything that moves the robot)."""
    current = await alatch()
    if current.latched:
        raise EstopEngaged(f"{current.message}; an operator must release it first.")


async def aengage(*, by: str) -> Latch:
    """Latch the stop (a press while latched keeps the first press's who and when)."""
    current = await alatch()
    if current.latched and current.by:
        return current
    # (A latch without who is one a link wrote back while the store had lost it: record this press.)
    engaged = Latch(latched=True, by=by, at=time.time())
    await apublish_state(LATCH_KEY, engaged.as_msg())
    return engaged


async def arecord_steps(engaged: Latch, steps: list[dict[str, Any]]) -> Latch:
    """Keep what each stop step did with the latch, so every page can show a failure."""
    current = await alatch()
    if not current.latched or current.at != engaged.at:
        return current  # released (or re-engaged) meanwhile: that newer state wins
    updated = Latch(latched=True, by=current.by, at=current.at, steps=steps)
    await apublish_state(LATCH_KEY, updated.as_msg())
    return updated


async def arelease(*, by: str) -> Latch:
    current = await alatch()
    released = Latch(latched=False, by=current.by, at=current.at, steps=current.steps,
                     released_by=by, released_at=time.time())
    await apublish_state(LATCH_KEY, released.as_msg())
    return released
