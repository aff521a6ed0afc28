"""Raise, update and end alerts where the robot link runs: one raiser, so no duplicates.

Scaled, only the link holding the lease runs this (a standby has no link to listen to); embedded,
the one server process does. Every web process only shows what it raised (the ``alerts`` key, one
frame to every page) and writes acknowledgements. The alerts open when a raiser stops are taken
over by the next one from the database, keeping their id and start.

Nothing here waits on the database or on delivery: a change is shown at once, then queued to be
kept (``records.save``, in order) and, when new, to be sent (``robot.alerts.delivery``).
"""

from __future__ import annotations

import asyncio
import logging
import time
import weakref
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from asgiref.sync import sync_to_async
from django.conf import settings

from robot import interface as ri
from robot.alerts import records, rules
from robot.alerts.book import AlertBook, Change, Record
from robot.introspection import diagnostics as diag
from robot.link.hosting import register_background
from robot.link.serving import register_operation
from robot.live.announce import aannounce, server_update
from robot.live.groups import ALERTS_KEY, LinkReply, LinkRequest
from robot.supervisor import spawn

if TYPE_CHECKING:
    from robot.link.connection import RobotLink

log = logging.getLogger(__name__)

TICK_S = 0.2
OFFLINE_GRACE_S = 2.0  # a reconnect's blink raises nothing
# Until the robot was first connected: a server and a simulator started together (`make run`) leave
# the simulator tens of seconds to listen on a loaded machine, and that start is no outage.
FIRST_CONNECT_GRACE_S = 30.0
EVENT_QUIET_S = 600.0  # an ERROR line with no repeat for this long ends
SAVE_ATTEMPTS = 3

# Called with each alert as it is raised (delivery beyond the tab); must not block.
raised_hooks: list[Callable[[Record], None]] = []
_engines: weakref.WeakKeyDictionary[Any, AlertEngine] = weakref.WeakKeyDictionary()


class AlertEngine:
    def __init__(self, link: RobotLink) -> None:
        self.link = link
        self.book = AlertBook(event_quiet_s=EVENT_QUIET_S)
        self.components: dict[str, diag.Component] = {}
        self.wake = asyncio.Event()
        self.dirty = True
        self.saves: asyncio.Queue[Record] = asyncio.Queue()
        self.saving: asyncio.Future | None = None
        self.offline_since: float | None = None
        self.ever_connected = False
        self.pressed: list[str] = []  # the bumpers pressed in the last message
        self._names = {ri.topic(k).name: k for k in ("battery_soc", "bumper_state", "rosout", "diagnostics")}

    def listen(self, name: str, msg_type: str, msg: dict[str, Any], t: float) -> None:
        key = self._names.get(name)
        if key == "battery_soc":
            self.apply(rules.battery(msg, low_percent=settings.BATTERY_LOW_PERCENT), t)
        elif key == "bumper_state":
            pressed = rules.pressed_bumpers(msg)
            if pressed and pressed != self.pressed:
                self.apply(rules.bumper(pressed, t), t)
            self.pressed = pressed
        elif key == "rosout":
            signal = rules.log_line(msg, t)
            if signal is not None and t - signal.at <= EVENT_QUIET_S:  # a line from long ago is history
                self.apply(signal, t)
        elif key == "diagnostics":
            new = diag.components_from_message(msg, t)
            if new:
                self.components = diag.merge(self.components, new, now=t)
                self._diagnostics(t)

    def apply(self, signal: rules.Signal, now: float) -> None:
        change = self.book.apply(signal, now)
        if change is not None:
            self.changed(change)

    def changed(self, change: Change) -> None:
        self.dirty = True
        self.wake.set()
        self.saves.put_nowait(replace(change.record))
        if change.what == "raised":
            log.warning("alert: %s", change.record.text)
            for hook in raised_hooks:
                try:
                    hook(replace(change.record))
                except Exception:
                    log.exception("an alert hook failed")

    def tick(self, now: float) -> None:
        link = self.link
        if link.connected:
            self.offline_since = None
            self.ever_connected = True
        elif self.offline_since is None:
            self.offline_since = now
        offline_for = now - (self.offline_since or now)
        starting = not self.ever_connected and offline_for < FIRST_CONNECT_GRACE_S
        for signal in rules.link(connected=link.connected, offline_for=offline_for,
                                 responding=link.dial.responding, grace_s=OFFLINE_GRACE_S):
            # Neither raised nor ended while starting: an outage handed over by the last raiser stays open.
            if not (starting and signal.key == "offline"):
                self.apply(signal, now)
        latch = link.latch.view(now)
        self.apply(rules.estop(latched=latch.latched, by=latch.by, at=latch.at), now)
        # Offline or hung, every component would go stale: that is the link's alert, not theirs.
        if link.connected and link.dial.responding:
            self._diagnostics(now)
        for change in self.book.expire(now):
            self.changed(change)

    def _diagnostics(self, now: float) -> None:
        signals = rules.diagnostics(self.components.values(), now=now, stale_after_s=settings.STALE_AFTER_S)
        for signal in signals:
            self.apply(signal, now)
        for change in self.book.end_missing("diag:", {s.key for s in signals}, now):
            self.changed(change)

    def acknowledge(self, alert_id: str, by: str, at: float) -> Change | None:
        change = self.book.ack(alert_id, by, at)
        if change is not None:
            self.changed(change)
        return change

    async def show(self) -> None:
        self.dirty = False
        msg = self.book.snapshot()
        await aannounce(ALERTS_KEY, dict(server_update(ALERTS_KEY, msg)), store=self.link.store)

    async def keep(self) -> None:
        """Write each change in order; a database away for a moment costs a retry, never the robot path."""
        while True:
            record = await self.saves.get()
            for attempt in range(SAVE_ATTEMPTS):
                try:
                    # Shielded: a stop lets the write under way finish (and waits for it) before the rest.
                    self.saving = spawn(sync_to_async(records.save)(record), awaited=True)
                    await asyncio.shield(self.saving)
                    break
                except Exception:
                    if attempt == SAVE_ATTEMPTS - 1:
                        log.exception("could not keep the alert %s", record.text)
                    await asyncio.sleep(1 + attempt)


async def run_alerts(link: RobotLink) -> None:
    engine = _engines[link] = AlertEngine(link)
    try:
        engine.book.load(await sync_to_async(records.open_records)())
    except Exception:
        log.exception("could not read the open alerts; starting with none")
    link.listeners.append(engine.listen)
    keeper = spawn(engine.keep())
    try:
        while True:
            engine.tick(time.time())
            if engine.dirty:
                await engine.show()
            try:
                await asyncio.wait_for(engine.wake.wait(), TICK_S)
            except TimeoutError:
                pass
            engine.wake.clear()
    finally:
        if engine.listen in link.listeners:
            link.listeners.remove(engine.listen)
        keeper.cancel()
        # What is not kept yet is kept now (briefly): the next raiser takes the open alerts over from there.
        try:
            async with asyncio.timeout(2):
                if engine.saving is not None:
                    await asyncio.gather(engine.saving, return_exceptions=True)
                while not engine.saves.empty():
                    await sync_to_async(records.save)(engine.saves.get_nowait())
        except Exception:
            log.warning("could not keep %d alert changes before stopping", engine.saves.qsize())


async def _ack(link: RobotLink, request: LinkRequest) -> LinkReply:
    engine = _engines.get(link)
    args = request.get("args") or {}
    change = engine and engine.acknowledge(str(args.get("id")), str(args.get("by")), float(args.get("at", 0)))
    if not change:
        return {"ok": False, "error_code": "not_found", "error": "No such alert is on"}
    return {"ok": True, "values": change.record.as_msg()}


def install() -> None:
    register_background("alerts", run_alerts)
    register_operation("alert_ack", _ack)
