"""One small supervisor for every long-running task of a process.

Every task the product starts has an owner that holds it, logs its failure and cancels it:
``Tasks`` (a link's, a socket's, a session's; ``spawn`` for the process's own) or, where the
owner's lifetime is one block, an ``asyncio.TaskGroup``.

``supervise(name, factory)`` runs ``factory()`` in a task; when it raises, the exception is
logged with its traceback and the task starts again after a backoff that doubles up to a
ceiling (and starts small again once a run lasted a while). A task that returns has finished
its work; a cancelled one stops (``cancel_and_wait``: several, in bounded time). ``health()`` is
what health reports: every supervised task of this process with its state, restarts and last error.
``hold(part)`` lists a part this process runs (the hosted link, the recorders, the uplink endpoint)
until ``release(part)``; ``running(kind)`` is how the others find it.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections.abc import Awaitable, Callable, Collection, Coroutine, Iterator
from dataclasses import asdict, dataclass
from typing import Any

log = logging.getLogger(__name__)

INITIAL_BACKOFF_S = 0.1
MAX_BACKOFF_S = 1.0  # short: after Redis returns, commands must work again within seconds
STABLE_AFTER_S = 10.0  # a run this long resets the backoff


@dataclass
class TaskHealth:
    name: str
    state: str = "running"  # running | restarting | finished
    restarts: int = 0
    last_error: str = ""
    last_error_at: float | None = None
    since: float = 0.0


_tasks: dict[str, TaskHealth] = {}


class Tasks:
    """The tasks of one owner. The event loop holds its tasks only weakly: one that waits on something
    nobody else holds would be collected mid-run, its caller having let go; so they are held here until
    they end. A failure nobody awaits is logged with its traceback."""

    def __init__(self) -> None:
        self._held: set[asyncio.Task[Any]] = set()

    def start[T](self, work: Coroutine[Any, Any, T], *, awaited: bool = False,
                 loop: asyncio.AbstractEventLoop | None = None) -> asyncio.Task[T]:
        """Run ``work`` in a task; ``awaited``: the caller takes its result (and its failure)."""
        task = asyncio.ensure_future(work, loop=loop)
        self._held.add(task)
        task.add_done_callback(self._held.discard)
        if not awaited:
            task.add_done_callback(_log_failure)
        return task

    def __len__(self) -> int:
        return len(self._held)

    async def wait(self, timeout: float) -> None:
        """Let the tasks end by themselves, for at most ``timeout``."""
        if self._held:
            await asyncio.wait(set(self._held), timeout=timeout)

    def cancel(self) -> None:
        for task in self._held:
            task.cancel()

    async def close(self, timeout: float) -> None:
        """Cancel every task and wait at most ``timeout`` for them to end."""
        await cancel_and_wait(list(self._held), timeout)


def _log_failure(task: asyncio.Task[Any]) -> None:
    if not task.cancelled() and (exc := task.exception()) is not None:
        log.error("background task %s failed", task.get_name(), exc_info=exc)


_process = Tasks()  # the process's own: supervised services, work that outlives who started it


def spawn[T](work: Coroutine[Any, Any, T], *, awaited: bool = False,
             loop: asyncio.AbstractEventLoop | None = None) -> asyncio.Task[T]:
    """A task of the process's own, held until it ends (``Tasks.start``)."""
    return _process.start(work, awaited=awaited, loop=loop)


def supervise(
    name: str,
    factory: Callable[[], Awaitable[None]],
    *,
    max_backoff_s: float = MAX_BACKOFF_S,
    transient: bool = False,
) -> asyncio.Task:
    """Run ``factory()`` under supervision. A ``transient`` task (one per driver, per socket)
    leaves health when it ends; the others stay listed as finished."""
    health = _tasks[name] = TaskHealth(name=name, since=time.time())

    async def run() -> None:
        backoff = INITIAL_BACKOFF_S
        try:
            while True:
                started = time.monotonic()
                health.state, health.since = "running", time.time()
                try:
                    await factory()
                    health.state = "finished"
                    return
                except asyncio.CancelledError:
                    health.state = "finished"
                    raise
                except Exception as exc:
                    # Cancelled, but a clean-up that failed on the way out (an ``except`` or ``finally``
                    # calling Redis or the database while it is down) raised in the CancelledError's
                    # place: restarted, the task would outlive its stop and keep its event loop open.
                    if (task := asyncio.current_task()) is not None and task.cancelling():
                        health.state = "finished"
                        raise asyncio.CancelledError from exc
                    if time.monotonic() - started >= STABLE_AFTER_S:
                        backoff = INITIAL_BACKOFF_S
                    health.state, health.restarts = "restarting", health.restarts + 1
                    health.last_error, health.last_error_at = f"{type(exc).__name__}: {exc}", time.time()
                    log.exception("%s failed; restarting in %.1f s (restart %d)", name, backoff, health.restarts)
                    await asyncio.sleep(backoff)
                    backoff = min(backoff * 2, max_backoff_s)
        finally:
            if transient and _tasks.get(name) is health:
                del _tasks[name]

    task = _process.start(run())
    task.set_name(name)  # named where a stop reports it still running
    return task


async def cancel_and_wait(tasks: Collection[asyncio.Future], timeout: float) -> None:
    """Cancel ``tasks`` and wait at most ``timeout`` for them to end, so a stop (zero the robot, flush,
    hand over) goes on in bounded time: a task cancelled during a database write in a worker thread
    ends only after the write (``history.storage.in_thread``), and that may be frozen."""
    for task in tasks:
        task.cancel()
    if tasks:
        _, running = await asyncio.wait(tasks, timeout=timeout)
        if running:
            log.warning("%d task(s) still running %g s after being cancelled: %s", len(running), timeout, running)


def health() -> dict[str, dict[str, object]]:
    return {name: asdict(h) for name, h in sorted(_tasks.items())}


def failing() -> list[str]:
    """Tasks waiting to restart after a failure."""
    return [name for name, h in sorted(_tasks.items()) if h.state == "restarting"]


def forget(name: str) -> None:
    _tasks.pop(name, None)


# The parts this process runs, newest last.
_parts: list[object] = []


def hold(part: object) -> None:
    _parts.append(part)


def release(part: object) -> None:
    with contextlib.suppress(ValueError):
        _parts.remove(part)


@contextlib.contextmanager
def holding[T](part: T) -> Iterator[T]:
    """``part`` is running for the length of the block."""
    hold(part)
    try:
        yield part
    finally:
        release(part)


def running[T](kind: type[T]) -> T | None:
    """The newest running part of ``kind``, if this process runs one."""
    return next((part for part in reversed(_parts) if isinstance(part, kind)), None)
