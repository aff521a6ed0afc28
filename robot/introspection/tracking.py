"""Where the robot link runs: follow the state machine and the diagnostics, and publish what
the pages show as server-written keys (``smach_graph``, ``smach_active``, ``diagnostics_summary``).

Both listen to every message the link receives (no extra subscription, the topics are
monitored) and publish only what changed: the graph when a container's structure changes,
the active states when they move, the diagnostics at once when a level changes and otherwise
at most once per ``DIAGNOSTICS_REFRESH_S`` (their values change with every message).
"""

from __future__ import annotations

import asyncio
import logging
import time
from typing import Any

from robot import interface as ri
from robot.introspection import diagnostics as diag
from robot.introspection import smach
from robot.link.connection import RobotLink
from robot.link.hosting import register_background
from robot.live.announce import aget_state, apublish_state
from robot.live.groups import DIAGNOSTICS_KEY, SMACH_ACTIVE_KEY, SMACH_GRAPH_KEY

log = logging.getLogger(__name__)

# Container status arrives ~1 Hz and on change; without one for this long, state_change decides.
STATUS_FRESH_S = 5.0
RECHECK_S = 1.0
DIAGNOSTICS_REFRESH_S = 1.0


class SmachTracker:
    """The containers and statuses heard so far, and the last state ``state_change`` named."""

    def __init__(self, *, fresh_s: float = STATUS_FRESH_S) -> None:
        self.fresh_s = fresh_s
        self.containers: dict[str, smach.Container] = {}
        self.statuses: dict[str, smach.Status] = {}
        self.state_change = ""
        self._structure, self._status = ri.topic("smach_structure").name, ri.topic("smach_status").name
        self._change = ri.topic("state_change").name

    def feed(self, name: str, msg: dict[str, Any], t: float) -> bool:
        """Take one message the link received; True if it may change what the page shows."""
        try:
            if name == self._structure:
                container = smach.container_from_message(msg)
                if self.containers.get(container.path) == container:
                    return False
                self.containers[container.path] = container
            elif name == self._status:
                path, status = smach.status_from_message(msg, t)
                self.statuses[path] = status
            elif name == self._change:
                self.state_change = str(msg.get("to_system_state") or "")
            else:
                return False
        except ValueError as exc:
            log.warning("ignored a malformed SMACH message on %s: %s", name, exc)
            return False
        return True

    def graph(self) -> dict[str, Any] | None:
        return smach.graph_view(self.containers) if self.containers else None

    def active(self, now: float) -> dict[str, Any] | None:
        if not self.containers:
            return None
        return smach.active_view(self.containers, self.statuses, self.state_change, now=now, fresh_s=self.fresh_s)


def _listen(link: RobotLink, tracker: Any, wake: asyncio.Event) -> Any:
    def listener(name: str, msg_type: str, msg: dict[str, Any], t: float) -> None:
        if tracker.feed(name, msg, t):
            wake.set()

    link.listeners.append(listener)
    return listener


async def _wait(wake: asyncio.Event, timeout: float) -> None:
    try:
        await asyncio.wait_for(wake.wait(), timeout)
    except TimeoutError:
        pass
    wake.clear()


async def track_smach(link: RobotLink, *, fresh_s: float = STATUS_FRESH_S) -> None:
    tracker = SmachTracker(fresh_s=fresh_s)
    change = (await aget_state("state_change")).get("state_change") or {}
    tracker.state_change = str(change.get("to_system_state") or "")
    wake = asyncio.Event()
    listener = _listen(link, tracker, wake)
    version, shown = None, None
    try:
        while True:
            await _wait(wake, RECHECK_S)  # also notices introspection going quiet
            graph = tracker.graph()
            if graph is not None and graph["version"] != version:
                version = graph["version"]
                await apublish_state(SMACH_GRAPH_KEY, graph)
            active = tracker.active(time.time())
            # The version names the graph the active states are drawn on: a grown graph re-tells them.
            if active is not None and (active := {**active, "version": version}) != shown:
                shown = active
                await apublish_state(SMACH_ACTIVE_KEY, active)
    finally:
        link.listeners.remove(listener)


class DiagnosticsTracker:
    def __init__(self) -> None:
        self.components: dict[str, diag.Component] = {}
        self.levels_changed = False
        self._name = ri.topic("diagnostics").name

    def feed(self, name: str, msg: dict[str, Any], t: float) -> bool:
        new = diag.components_from_message(msg, t) if name == self._name else None
        if not new:
            return False
        merged = diag.merge(self.components, new, now=t)
        self.levels_changed = self.levels_changed or diag.changed_levels(self.components, merged)
        self.components = merged
        return True


async def track_diagnostics(link: RobotLink, *, refresh_s: float = DIAGNOSTICS_REFRESH_S) -> None:
    tracker = DiagnosticsTracker()
    wake = asyncio.Event()
    listener = _listen(link, tracker, wake)
    sent_at = 0.0
    try:
        while True:
            await wake.wait()
            wake.clear()
            deadline = sent_at + refresh_s
            while not tracker.levels_changed and (left := deadline - time.monotonic()) > 0:
                await _wait(wake, left)
            tracker.levels_changed = False
            sent_at = time.monotonic()
            await apublish_state(DIAGNOSTICS_KEY, diag.summary(tracker.components))
    finally:
        link.listeners.remove(listener)


def install() -> None:
    register_background("introspection-smach", track_smach)
    register_background("introspection-diagnostics", track_diagnostics)
