"""The link's status (what pages and /healthz show) and its upkeep: the heartbeat, and following
the shared E-STOP latch (``LatchWatch``, read by alerts and pages through ``LatchView``)."""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from django.conf import settings

from robot.link.dial import Dial
from robot.link.guard import CmdVelGuard
from robot.link.subscriptions import Subscriptions
from robot.live.announce import aannounce, aannounce_status, server_update
from robot.live.groups import LATCH_KEY, LinkStatus
from robot.live.latchstate import Latch
from robot.live.state import LINK_HEARTBEAT_S, StateStore
from robot.supervisor import failing, running

log = logging.getLogger(__name__)

LATCH_SETTLE_S = 3.0  # a stop's store write normally lands within milliseconds


class HostedUplink:
    """The face of the uplink endpoint the link's status reads (robot.uplink.hosting holds it while it serves)."""

    def status(self) -> dict[str, Any]:
        raise NotImplementedError


def uplink_status() -> dict[str, Any] | None:
    """For the link's status: None when this server dials the robot itself."""
    if not settings.UPLINK:
        return None
    endpoint = running(HostedUplink)
    if endpoint is None:
        return {"connected": False, "why": "the uplink endpoint is not running in the link's process"}
    return endpoint.status()


@dataclass(frozen=True)
class LatchView:
    """The E-STOP latch as this link holds it: engaged or not, who pressed it and when."""

    latched: bool
    by: str
    at: float


class LatchWatch:
    """This link's E-STOP: its guard (set when the link starts), its own last press, the shared latch."""

    def __init__(self, store: StateStore) -> None:
        self.store = store
        self.guard: CmdVelGuard | None = None
        self._msg: dict[str, Any] = {}  # the shared latch as last read
        # The last E-STOP this link took (epoch, who): written to the shared store if the store missed it.
        self._pressed_at = 0.0
        self._pressed_by = ""

    def pressed(self, at: float, by: str) -> None:
        self._pressed_at = max(self._pressed_at, at)
        self._pressed_by = by or self._pressed_by

    def view(self, now: float) -> LatchView:
        """Who pressed the E-STOP and when, as this link knows it: its own last press, else the stored latch."""
        by = str(self._msg.get("by") or self._pressed_by or "")
        at = float(self._pressed_at or self._msg.get("at") or now)
        return LatchView(latched=bool(self.guard is not None and self.guard.latched), by=by, at=at)

    async def sync(self) -> None:
        """Follow the shared latch; if the store lost it (Redis restarted empty) while this link
        holds a stop, write it back: a latch ends only by an operator's release."""
        try:
            entry = (await self.store.aget_many([LATCH_KEY])).get(LATCH_KEY)
            if self.guard is None:
                return
            if entry is not None:
                self._msg = dict(entry.get("msg") or {})
            # A stop or release this link took moments ago may not be in the store yet: reading
            # the store then would undo it, or write back a latch without who and when.
            if not self.guard.settled(LATCH_SETTLE_S):
                return
            stored = Latch.from_msg(self._msg if entry is not None else None)
            if self.guard.latched and self._pressed_at > max(stored.at, stored.released_at) and not stored.latched:
                log.warning("the shared store missed an E-STOP this link took: writing it")
                pressed = Latch(latched=True, by=self._pressed_by, at=self._pressed_at)
                await aannounce(LATCH_KEY, dict(server_update(LATCH_KEY, pressed.as_msg())), store=self.store)
            elif entry is not None:
                self.guard.sync(bool(self._msg.get("latched")))
            elif self.guard.latched:
                log.warning("the shared store lost the E-STOP latch: writing it back")
                msg = self._msg if self._msg.get("latched") else {"latched": True}
                await aannounce(LATCH_KEY, dict(server_update(LATCH_KEY, msg)), store=self.store)
        except Exception:
            log.exception("could not read the E-STOP latch")


class Upkeep:
    """The link's status, published on every change and every heartbeat."""

    def __init__(self, dial: Dial, subscriptions: Subscriptions, latch: LatchWatch, *, store: StateStore,
                 holder: Callable[[], str | None]) -> None:
        self.dial = dial
        self.subscriptions = subscriptions
        self.latch = latch
        self.store = store
        self.holder = holder  # scaled mode: who holds the link's lease
        self.command_path = True  # until a ping over the request channel goes unanswered

    def status(self) -> LinkStatus:
        dial = self.dial
        return {
            "type": "robot.status", "connected": dial.connected, "url": dial.url,
            "since": dial.since, "attempts": dial.attempts, "link_alive": time.time(),
            "command_path": self.command_path, "failing_tasks": failing(),
            "holder": self.holder(),
            "failed_subscriptions": dict(self.subscriptions.failed),
            "connecting_until": dial.connecting_until,
            "responding": dial.responding, "heard_at": dial.heard_at, "ros": dial.ros_version,
        }

    async def set_command_path(self, ok: bool) -> None:
        """What the last ping over the request channel found, published every time: a store
        that came back empty from an outage has the link's status again within a second."""
        if ok != self.command_path:
            (log.info if ok else log.error)("command path %s", "answers again" if ok else "DOWN: a ping got no answer")
            self.command_path = ok
        await self.publish()

    async def publish(self) -> None:
        try:
            await aannounce_status({**self.status(), "uplink": uplink_status()}, store=self.store)
        except Exception:
            log.exception("could not publish link status")

    async def heartbeat(self) -> None:
        while not self.dial.stopped:
            await asyncio.sleep(LINK_HEARTBEAT_S)
            self.dial.count_attempts()
            await self.latch.sync()
            await self.publish()
