"""One small supervisor for every long-running task of a process.

``supervise(name, factory)`` runs ``factory()`` in a task; when it raises, the exception is
logged with its traceback and the task starts again after a backoff that doubles up to a
ceiling (and starts small again once a run lasted a while). A task that returns has finished
its work; a cancelled one stops. ``health()`` is what health reports: every supervised task
of this process with its state, restarts and last error.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Awaitable, Callable
from dataclasses import asdict, dataclass

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


def stop_requested() -> bool:
    """True once the running task has been cancelled, even when a library (a Redis client in the
    middle of a read) turned the CancelledError into an error of its own: a loop that catches
    errors and carries on must stop then, or the task never ends and neither does its event loop."""
    task = asyncio.current_task()
    return task is not None and task.cancelling() > 0


def end_if_cancelled() -> None:
    """End the running task if it was cancelled, for a loop to call each round: Python 3.11's
    ``wait_for`` (inside redis-py's writes, for one) can return normally in a task cancelled just
    then, the cancellation lost, and the loop would go on for ever."""
    if stop_requested():
        raise asyncio.CancelledError


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
                    if stop_requested():
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

    return asyncio.ensure_future(run())


def health() -> dict[str, dict[str, object]]:
    return {name: asdict(h) for name, h in sorted(_tasks.items())}


def failing() -> list[str]:
    """Tasks waiting to restart after a failure."""
    return [name for name, h in sorted(_tasks.items()) if h.state == "restarting"]


def forget(name: str) -> None:
    _tasks.pop(name, None)
