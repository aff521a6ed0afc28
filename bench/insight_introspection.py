"""The state machine graph and the diagnostics through the real product (simulator + Daphne,
embedded default): a section of bench/insight.py.

``PAGES`` live sockets watch what the state machine page and the dashboard's alert strip watch.

- ``smach_event_to_graph_*_ms``: an operator's event (POST /api/robot/event/, alternately
  ``manual_start`` and ``aborted``) until the LAST of the pages has the new active state
  (``smach_active``), i.e. the time from a click on a transition to every graph highlighting it.
- ``diagnostic_level_to_page_*_ms``: motors switched off or on (POST /api/robot/motors/) until
  the last page has the motors component's new level (``diagnostics_summary``), i.e. until every
  dashboard can raise or clear the alert.

As a section, ``run(stack)`` returns ``(name, value)`` lines; on its own (``.venv/bin/python
bench/insight_introspection.py``, no arguments) it starts its own stack and prints ``name: value``.
"""

from __future__ import annotations

import asyncio
import json
import sys
import time
import urllib.request
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from _stats import quantile  # noqa: E402
from websockets.asyncio.client import connect  # noqa: E402

from robot.live.groups import DIAGNOSTICS_KEY, SMACH_ACTIVE_KEY  # noqa: E402
from tests.stack import Stack  # noqa: E402

PAGES = 20
ROUNDS = 10
START_TIMEOUT_S = 60.0
STEP_TIMEOUT_S = 15.0
MOTORS = "RosAria: Motors"

Check = Callable[[str, dict[str, Any]], bool]  # (key, msg) -> the change a page waits for


def _post(stack: Stack, cookie: str, path: str, body: dict[str, Any]) -> None:
    token = next(part.split("=", 1)[1] for part in cookie.split("; ") if part.startswith("csrftoken="))
    request = urllib.request.Request(f"{stack.url}{path}", data=json.dumps(body).encode(), method="POST", headers={
        "Cookie": cookie, "X-CSRFToken": token, "Content-Type": "application/json", "Referer": stack.url})
    with urllib.request.urlopen(request, timeout=10) as answer:
        answer.read()


class Page:
    """One live socket; ``wait`` resolves when an update passes the current check."""

    def __init__(self, ws: Any) -> None:
        self.ws = ws
        self.check: Check | None = None
        self.seen = asyncio.Event()

    async def read(self) -> None:
        async for raw in self.ws:
            frame = json.loads(raw)
            for update in frame.get("updates") or ():
                if self.check is not None and self.check(update["key"], update["msg"]):
                    self.seen.set()

    def expect(self, check: Check) -> None:
        self.check = check
        self.seen.clear()


def _leaves(path: str) -> Check:
    return lambda key, msg: key == SMACH_ACTIVE_KEY and msg.get("leaves") == [path]


def _motors(level: int) -> Check:
    return lambda key, msg: key == DIAGNOSTICS_KEY and any(
        c["name"] == MOTORS and c["level"] == level for c in msg.get("components", []))


async def _round(pages: list[Page], check: Check, act: Callable[[], None], timeout: float) -> float:
    for page in pages:
        page.expect(check)
    t0 = time.perf_counter()
    await asyncio.to_thread(act)
    await asyncio.wait_for(asyncio.gather(*(p.seen.wait() for p in pages)), timeout)
    return (time.perf_counter() - t0) * 1000


async def measure(stack: Stack) -> dict[str, str]:
    cookie = stack.login_cookie("otto")
    url = f"ws://127.0.0.1:{stack.web_port}/ws/live/"
    sockets = [await connect(url, origin=stack.url, additional_headers={"Cookie": cookie}, max_size=None)
               for _ in range(PAGES)]
    pages = [Page(ws) for ws in sockets]
    readers = [asyncio.create_task(p.read()) for p in pages]
    try:
        for page in pages:
            page.expect(_leaves("/SM_ROOT/suspension"))
            await page.ws.send(json.dumps({"action": "watch", "keys": [SMACH_ACTIVE_KEY, DIAGNOSTICS_KEY]}))
        # A fresh simulator spends its start-up in startup; the stored value may already say suspension.
        await asyncio.wait_for(asyncio.gather(*(p.seen.wait() for p in pages)), START_TIMEOUT_S)
        graph, diagnostics = [], []
        for k in range(ROUNDS):
            event, state = ("manual_start", "/SM_ROOT/manual") if k % 2 == 0 else ("aborted", "/SM_ROOT/suspension")
            graph.append(await _round(pages, _leaves(state),
                                      lambda e=event: _post(stack, cookie, "/api/robot/event/", {"event": e}),
                                      STEP_TIMEOUT_S))
        for k in range(ROUNDS):
            on = k % 2 == 1
            diagnostics.append(await _round(pages, _motors(0 if on else 1),
                                            lambda on=on: _post(stack, cookie, "/api/robot/motors/", {"enabled": on}),
                                            STEP_TIMEOUT_S))
    finally:
        for task in readers:
            task.cancel()
        for ws in sockets:
            await ws.close()
    graph.sort()
    diagnostics.sort()
    return {
        "introspection_pages": str(PAGES),
        "smach_event_to_graph_p50_ms": f"{quantile(graph, 0.5):.1f}",
        "smach_event_to_graph_max_ms": f"{graph[-1]:.1f}",
        "diagnostic_level_to_page_p50_ms": f"{quantile(diagnostics, 0.5):.1f}",
        "diagnostic_level_to_page_max_ms": f"{diagnostics[-1]:.1f}",
    }


def run(stack: Stack) -> list[tuple[str, str]]:
    """This section's figures as (name, value) lines (the stack is up, the robot online); leaves the
    robot in suspension with its motors on."""
    return list(asyncio.run(measure(stack)).items())


def main() -> None:
    with Stack() as stack:
        stack.wait_robot_online()
        for name, value in run(stack):
            print(f"{name}: {value}", flush=True)


if __name__ == "__main__":
    main()
