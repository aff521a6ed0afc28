"""What this web process sees of its backing services, on every open page.

The link's status reaches pages through Redis; with Redis (or the database, or the audit) gone a
page would go on showing the last status it got. So each web process checks its services itself,
every second, with the same checks as /healthz, and adds what is down to the status frame of its
own sockets (``Hub.set_services``), saying what that means and that the E-STOP still works.
"""

from __future__ import annotations

import asyncio
import weakref
from concurrent.futures import ThreadPoolExecutor

from django.db import connection

from dashboard.health import CHECKS, Check
from robot.live.hub import Hub
from robot.supervisor import supervise

EVERY_S = 1.0
CHECK_TIMEOUT_S = 2.0
MEANING = {
    "redis": "Redis is unreachable: live values may be stale and commands are refused",
    "database": "The database is unreachable: pages and commands that need it fail",
    "audit": "The audit log cannot be written: commands are refused",
    "command_path": "The robot link does not answer requests: commands cannot reach the robot",
}
# The checks touch the database and Redis with blocking clients: one thread of their own, so a
# frozen service holds up nothing else (and the database connection is reused).
_executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="services-watch")
_watches: weakref.WeakKeyDictionary[Hub, asyncio.Task] = weakref.WeakKeyDictionary()


def down_services() -> dict[str, str]:
    checks: list[Check] = []
    for run in CHECKS:
        try:
            check = run()
        except Exception as exc:  # a check that breaks says its service is down, never the watch
            check = Check(run.__name__.removeprefix("check_"), False, str(exc))
        if check is not None:
            checks.append(check)
    down = {c.name: MEANING.get(c.name, c.detail or c.name) for c in checks if not c.ok}
    if "database" in down:
        connection.close()  # this thread's broken connection; the next check opens a new one
    return down


async def watch(hub: Hub) -> None:
    loop = asyncio.get_running_loop()
    while True:
        try:
            down = await asyncio.wait_for(loop.run_in_executor(_executor, down_services), CHECK_TIMEOUT_S)
        except TimeoutError:
            down = {**hub.services_down, "checks": "This server's health checks do not answer"}
        hub.set_services(down)
        await asyncio.sleep(EVERY_S)


def ensure_watching(hub: Hub) -> None:
    task = _watches.get(hub)
    if task is None or task.done():
        _watches[hub] = supervise("live.services-watch", lambda: watch(hub))
