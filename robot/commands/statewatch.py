"""Follow the state machine through what the robot reports on ``state_change``.

Reads the store's ring of recent ``state_change`` messages (kept by the link in whichever
process hosts it), so it works the same in the embedded default and across processes.

Only what the robot reported since the link last (re)connected counts: a robot that restarted
begins again in startup, and announces that before the link is back, so the changes heard
before the restart are history, not its state. Until a change arrives, the state comes from
the SMACH status the robot repeats about once a second.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable, Iterable
from typing import Any

from robot import interface as ri
from robot.live.groups import STATUS_KEY
from robot.live.state import StateStore, get_store

KEY = "state_change"
SMACH_KEY = "smach_status"
POLL_S = 0.02

Change = dict[str, Any]  # a SystemState message: event, from_system_state, to_system_state
Entry = dict[str, Any]  # a stored update: {"msg": ..., "t": when the link received it, ...}


def connected_since(status: Entry | None) -> float | None:
    """When the link last connected to the robot; None while it is not connected."""
    if not status or not status.get("connected"):
        return None
    return float(status.get("since") or 0.0)


def leaf_from_smach(entries: Iterable[Entry]) -> str:
    """The active leaf from SMACH container statuses (latest per container), "" if they do not
    reach down to one (a container whose own status has not come yet)."""
    active: dict[str, list[str]] = {}
    for entry in sorted(entries, key=lambda e: float(e.get("t", 0))):
        msg = entry.get("msg") or {}
        if msg.get("path"):
            active[str(msg["path"])] = list(msg.get("active_states") or [])
    if not active:
        return ""
    path = min(active, key=lambda p: p.count("/"))  # the root container
    while True:
        states = active.get(path) or []
        if not states:
            return ""
        child = f"{path}/{states[0]}"
        if child not in active:
            return states[0] if states[0] in ri.TOP_LEVEL_STATES | ri.BEHAVIOUR_STATES else ""
        path = child


class StateWatch:
    """Start it before sending anything: every change after ``start`` is heard, in order."""

    def __init__(self, store: StateStore | None = None) -> None:
        self._store = store or get_store()
        self._last: Entry | None = None
        self._since: float | None = None
        self.state = ""  # the latest state the robot reported since the link connected; "" if unknown

    def _current(self, entry: Entry | None) -> bool:
        return entry is not None and self._since is not None and float(entry.get("t", 0)) >= self._since

    async def _read(self) -> str:
        recent = await self._store.aget_recent(KEY)
        latest = recent[-1] if recent else (await self._store.aget_many([KEY])).get(KEY)
        self._last = latest
        self._since = connected_since((await self._store.aget_many([STATUS_KEY])).get(STATUS_KEY))
        if self._current(latest):
            assert latest is not None
            return str(latest.get("msg", {}).get("to_system_state", ""))
        return leaf_from_smach(e for e in await self._store.aget_recent(SMACH_KEY) if self._current(e))

    async def start(self, settle_s: float = 0.0) -> str:
        """The state now; if the robot has said nothing since the link connected, wait up to
        ``settle_s`` for its next report (its SMACH status repeats about once a second)."""
        deadline = time.monotonic() + settle_s
        while not (state := await self._read()) and self._since is not None and time.monotonic() < deadline:
            await asyncio.sleep(POLL_S * 5)
        self.state = state
        return state

    async def _new_changes(self) -> list[Change]:
        recent = await self._store.aget_recent(KEY)
        last = self._last
        if last is not None:
            for i in range(len(recent) - 1, -1, -1):
                if recent[i] == last:
                    recent = recent[i + 1:]
                    break
            else:  # the ring has moved past the marker: what is newer than it
                recent = [e for e in recent if float(e.get("t", 0)) > float(last.get("t", 0))]
        if recent:
            self._last = recent[-1]
        return [entry["msg"] for entry in recent if self._since is None or self._current(entry)]

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
