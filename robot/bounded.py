"""Waits that end on time even when what they wait on ignores its cancellation.

``asyncio.wait_for`` and ``gather`` after ``cancel()`` wait until the cancelled task has really
ended. A task whose cancellation was lost (a library turned it into an error of its own and
carried on; Python 3.11's own ``wait_for``, inside redis-py's writes, can return normally in a
task cancelled just then) holds its caller for as long as it runs, and a stop that must zero
the robot, flush and hand over waits with it. These waits cancel, wait a bounded time, and go
on, naming what did not end.
"""

from __future__ import annotations

import asyncio
import io
import logging
from collections.abc import Awaitable, Iterable

log = logging.getLogger(__name__)


async def within[T](awaitable: Awaitable[T], timeout: float) -> T:
    """``awaitable``'s result, or TimeoutError after ``timeout`` seconds (it is cancelled, not waited for)."""
    task = asyncio.ensure_future(awaitable)
    try:
        await asyncio.wait({task}, timeout=timeout)
    finally:
        if not task.done():  # timed out, or the caller was cancelled
            task.cancel()
            task.add_done_callback(_forget)
    if not task.done():
        raise TimeoutError(f"did not finish within {timeout:g} s")
    return task.result()


async def cancel_within(tasks: Iterable[asyncio.Future], timeout: float) -> set[asyncio.Future]:
    """Cancel ``tasks`` and wait at most ``timeout`` for them to end; those still running are logged
    with where they are, and returned."""
    tasks = set(tasks)
    for task in tasks:
        task.cancel()
    if not tasks:
        return set()
    _, pending = await asyncio.wait(tasks, timeout=timeout)
    if pending:
        log.warning("%d task(s) did not end within %g s of being cancelled:%s", len(pending), timeout,
                    describe(pending))
        for task in pending:
            task.add_done_callback(_forget)
    return pending


def describe(tasks: Iterable[asyncio.Future]) -> str:
    out = io.StringIO()
    for task in tasks:
        out.write("\n")
        if isinstance(task, asyncio.Task):
            task.print_stack(file=out)
        else:
            out.write(repr(task))
    return out.getvalue()


def _forget(task: asyncio.Future) -> None:
    """What an abandoned task ends with has nobody to go to: read it, so asyncio does not report it."""
    if not task.cancelled():
        task.exception()
