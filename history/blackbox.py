"""The black box: incidents around the moments that matter, kept in full by the recorder.

``offer`` (a link listener, on the event-loop thread) checks the trigger topics (bumpers, log,
diagnostics, heard whatever their recording policy) for a trigger. The loop opens an incident
for each trigger and for an E-STOP seen in the shared latch, adopts the incidents other
processes opened (a marked moment), and has the recorder hold each window: the recorder keeps
every message of the black box's topics an admin records every N seconds (and every camera
frame) in it, those of the seconds before from its ring. Topics recorded every message are
stored anyway; a topic the admin switched off stays unrecorded, incident or not.

A restart loses the recorder's ring (the minute before an incident still open then), never what
it took: a clean stop writes it.
"""

from __future__ import annotations

import asyncio
import logging
import time
from typing import Any

from django.conf import settings

from history.incidents import TRIGGER_KEYS, Triggers, incident_open, incidents_to_capture
from history.models import Incident
from history.recorder import Recorder
from history.storage import FailureLog, in_thread
from robot import interface as ri
from robot.live.keys import LATCH_KEY
from robot.supervisor import holding, running

log = logging.getLogger(__name__)

TICK_S = 0.25
ADOPT_EVERY_S = 1.0
LINK_HOLDER = "blackbox"


class BlackBox:
    def __init__(self) -> None:
        self.topics = {ri.topic(key).name: ri.topic(key).type for key in TRIGGER_KEYS}
        self.triggers = Triggers()
        self.fired: list[tuple[str, float, str, str]] = []  # (kind, t, summary, by)
        self._latch_at: float | None = None

    # --- on the event-loop thread: never blocks --------------------------------------

    def offer(self, name: str, msg_type: str, msg: dict[str, Any], t: float) -> None:
        if name not in self.topics:
            return
        fired = self.triggers.check(name, msg)
        if fired is not None:
            self.fired.append((fired[0], t, fired[1], ""))

    def adopt(self, incident: Incident) -> None:
        recorder = running(Recorder)
        if recorder is not None and incident.pk not in recorder.windows:
            recorder.hold(incident.pk, incident.start, incident.end)

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
        if (recorder := running(Recorder)) is not None:
            recorder.release_past(time.time() - settings.HISTORY_FLUSH_S)

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
                            # again each second: a no-op once held
                            link.subscriptions.subscribe(name, msg_type, holder=LINK_HOLDER)
                        await self.adopt_open()
                    failures.ok()
                except Exception:
                    failures.failed()
                await asyncio.sleep(TICK_S)
        finally:
            if self.offer in link.listeners:
                link.listeners.remove(self.offer)
            for name in self.topics:
                link.subscriptions.unsubscribe(name, holder=LINK_HOLDER)


async def run_blackbox(link: Any) -> None:
    """The background service registered in ``HistoryConfig.ready``."""
    with holding(BlackBox()) as box:
        await box.run(link)
