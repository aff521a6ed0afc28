"""The black box: the last minute of the chosen topics in memory, kept in full around incidents.

``offer`` (a link listener, on the event-loop thread) appends every message of the black
box's topics to a ring of the last ``INCIDENT_BEFORE_S`` seconds, checks it for a trigger,
and queues it for storage when it falls in an open incident's window. The loop opens an
incident for each trigger and for an E-STOP seen in the shared latch, adopts the incidents
other processes opened (a marked moment), writes the ring's part of each new window and the
messages since, and hands the camera recorder the same windows.

What it writes: every message of the topics an admin records every N seconds (the default
policies cover all of ``TOPIC_KEYS``), so inside an incident they are at full rate. Topics
recorded every message are already stored by the recorder; a topic the admin switched off
stays unrecorded, incident or not.

A restart loses the ring (the minute before an incident still open then), never what was
queued: a clean stop writes it.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Sequence
from typing import Any

from django.conf import settings

from history.camerarec import CameraRecorder
from history.capture import Capture
from history.incidents import Triggers, incident_open, incidents_to_capture
from history.models import Incident
from history.recorder import Recorder
from history.storage import FailureLog, Pending, Row, encode, in_thread, write_rows
from robot import interface as ri
from robot.live.keys import LATCH_KEY
from robot.supervisor import holding, running

log = logging.getLogger(__name__)

TOPIC_KEYS = (
    "robot_pose", "odom", "amcl_pose", "plan", "move_base_status", "state_change", "robot_mode",
    "emotional_state", "battery_soc", "bumper_state", "motors_state", "diagnostics", "rosout",
)
TICK_S = 0.25
ADOPT_EVERY_S = 1.0
LINK_HOLDER = "blackbox"


class BlackBox(Capture[Pending]):
    def __init__(self, *, writer: Callable[[Sequence[Row]], int] = write_rows) -> None:
        super().__init__(writer, "writing incident messages")
        self.topics = {ri.topic(key).name: ri.topic(key).type for key in TOPIC_KEYS}
        self.triggers = Triggers()
        self.fired: list[tuple[str, float, str, str]] = []  # (kind, t, summary, by)
        self._latch_at: float | None = None

    # --- on the event-loop thread: never blocks --------------------------------------

    def offer(self, name: str, msg_type: str, msg: dict[str, Any], t: float) -> None:
        if name not in self.topics:
            return
        entry = self._remember(t, (name, msg_type, msg))
        if self._incident_at(t) is not None:
            self._keep(entry)
        fired = self.triggers.check(name, msg)
        if fired is not None:
            self.fired.append((fired[0], t, fired[1], ""))

    def _keep(self, entry: list[Any]) -> None:
        entry[2] = True
        t, (name, msg_type, msg), _ = entry
        # The topics recorded every N seconds are those an incident keeps every message of.
        if (recording := running(Recorder)) is not None and name in recording.periodic:
            self._pending.append((name, msg_type, msg, t))

    def adopt(self, incident: Incident) -> None:
        if incident.pk in self.windows:
            return
        self.windows[incident.pk] = (incident.start, incident.end)
        for entry in self._unkept(incident.start, incident.end):
            self._keep(entry)
        if (camera := running(CameraRecorder)) is not None:
            camera.hold(incident.pk, incident.start, incident.end)

    # --- the loop ---------------------------------------------------------------------

    async def check_latch(self, store: Any) -> None:
        entry = (await store.aget_many([LATCH_KEY])).get(LATCH_KEY) or {}
        msg = entry.get("msg") or {}
        at = float(msg.get("at") or 0.0)
        if self._latch_at is not None and msg.get("latched") and at > self._latch_at:
            self.fired.append((Incident.Kind.ESTOP, at, "E-STOP pressed", str(msg.get("by") or "")))
        # The first reading is the latch as it was before this black box started: no incident.
        self._latch_at = max(at, self._latch_at or 0.0)

    async def open_fired(self) -> None:
        while self.fired:
            kind, t, summary, by = self.fired[0]
            incident = await in_thread(incident_open, kind=kind, t=t, summary=summary, by=by)
            self.fired.pop(0)  # only once stored: a database outage keeps it for the next tick
            log.info("incident %s: %s at %.3f (%s)", incident.pk, kind, t, summary)
            self.adopt(incident)

    async def adopt_open(self) -> None:
        for incident in await in_thread(incidents_to_capture):
            self.adopt(incident)
        past = time.time() - settings.HISTORY_FLUSH_S
        self.release_past(past)
        if (camera := running(CameraRecorder)) is not None:
            camera.release_past(past)

    def _batch(self, pending: list[Pending]) -> list[Row]:
        return encode(pending, {}, default_max=settings.HISTORY_MAX_MESSAGE_BYTES)[0]

    async def run(self, link: Any) -> None:
        if self.offer not in link.listeners:
            link.listeners.append(self.offer)
        failures = FailureLog("the black box")
        next_adopt = 0.0
        try:
            while True:
                try:
                    await self.check_latch(link.store)
                    await self.open_fired()
                    if time.monotonic() >= next_adopt:
                        next_adopt = time.monotonic() + ADOPT_EVERY_S
                        for name, msg_type in self.topics.items():
                            link.subscribe(name, msg_type, holder=LINK_HOLDER)  # again each second: a no-op once held
                        await self.adopt_open()
                    await self.flush()
                    failures.ok()
                except Exception:
                    failures.failed()
                await asyncio.sleep(TICK_S)
        finally:
            if self.offer in link.listeners:
                link.listeners.remove(self.offer)
            for name in self.topics:
                link.unsubscribe(name, holder=LINK_HOLDER)
            await self.flush()


async def run_blackbox(link: Any) -> None:
    """The background service registered in ``HistoryConfig.ready``."""
    with holding(BlackBox()) as box:
        await box.run(link)
