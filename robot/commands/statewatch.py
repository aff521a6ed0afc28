"""Follow the state machine through what the robot reports on ``state_change``.

Reads the store's ring of recent ``state_change`` messages (kept by the link in whichever
process hosts it), so it works the same in the embedded default and across processes.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from typing import Any

from robot.live.state import StateStore, get_store

KEY = "state_change"
POLL_S = 0.02

Change = dict[str, Any]  # a SystemState message: event, from_system_state, to_system_state


class StateWatch:
    """Start it before sending anything: every change after ``start`` is heard, in order."""

    def __init__(self, store: StateStore | None = None) -> None:
        self._store = store or get_store()
        self._last: dict[str, Any] | None = None
        self.state = ""  # the latest state the robot reported; "" if it never did

    async def start(self) -> str:
        recent = await self._store.aget_recent(KEY)
        latest = recent[-1] if recent else (await self._store.aget_many([KEY])).get(KEY)
        self._last = latest
        self.state = (latest or {}).get("msg", {}).get("to_system_state", "")
        return self.state

    async def _new_changes(self) -> list[Change]:
        recent = await self._store.aget_recent(KEY)
        if self._last is not None:
            for i in range(len(recent) - 1, -1, -1):
                if recent[i] == self._last:
                    recent = recent[i + 1:]
                    break
        if recent:
            self._last = recent[-1]
        return [entry["msg"] for entry in recent]

    async def wait_for(self, accept: Callable[[Change], bool], timeout: float) -> Change | None:
        """The first new change ``accept`` takes, or None after ``timeout`` s; ``state`` follows every change."""
        deadline = time.monotonic() + timeout
        while True:
            for change in await self._new_changes():
                self.state = change.get("to_system_state", "")
                if accept(change):
                    return change
            if time.monotonic() >= deadline:
                return None
            await asyncio.sleep(POLL_S)
