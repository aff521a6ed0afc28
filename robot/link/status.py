"""The link's connection status (what pages and /healthz show) and its upkeep: the heartbeat,
following the shared E-STOP latch, watching for rosbridge's port, reconnecting when asked."""

from __future__ import annotations

import asyncio
import logging
import re
import time
from typing import Any
from urllib.parse import urlsplit

from django.conf import settings

from robot.link.core import LinkCore
from robot.live.announce import aannounce, aannounce_status, server_update
from robot.live.groups import LATCH_KEY, LinkStatus
from robot.live.latchstate import Latch
from robot.live.state import LINK_HEARTBEAT_S
from robot.supervisor import failing, running

log = logging.getLogger(__name__)

# While the robot is away, how often to look whether rosbridge's port is listening again.
PORT_WATCH_S = 0.2
LATCH_SETTLE_S = 3.0  # a stop's store write normally lands within milliseconds
# ROS 1 rosbridge answers a subscription it cannot make (a message package the robot lacks) only on
# /rosout, as an error from its own node naming the request id roslibpy gave it.
ROSBRIDGE_NODE = "/rosbridge_websocket"
_FAILED_SUBSCRIBE = re.compile(r"\[id: subscribe:(?P<topic>/[^\]]*?):\d+\] subscribe: (?P<error>.*)", re.S)


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


class Upkeep(LinkCore):
    def _note_refusal(self, text: str) -> None:
        refused = _FAILED_SUBSCRIBE.search(text)
        if refused is None or refused["topic"] not in self._subscriptions:
            return
        first = refused["topic"] not in self.failed_subscriptions
        self.failed_subscriptions[refused["topic"]] = refused["error"].strip()
        if first:
            log.error("the robot refused the subscription to %s (tried again on every reconnect): %s",
                      refused["topic"], refused["error"].strip())
            self._spawn(self.publish_status())

    def _on_ready(self, at: float) -> None:
        if self._stopped:
            return
        self.failed_subscriptions.clear()  # roslibpy subscribes again now; refusals come back on /rosout
        self.connected, self.since, self.attempts = True, at, 0
        self.heard_at, self.responding = at, True
        log.info("robot link connected to %s", self.url)
        self._spawn(self.publish_status())

    def _on_close(self) -> None:
        if self._stopped:
            return
        if self.connected:
            log.warning("robot link lost %s; reconnecting", self.url)
            self.since = time.time()
            if self.guard is not None:
                self.guard.lost()
        self.connected = False
        self.attempts += 1
        self._spawn(self.publish_status())

    def status(self) -> LinkStatus:
        return {
            "type": "robot.status", "connected": self.connected, "url": self.url,
            "since": self.since, "attempts": self.attempts, "link_alive": time.time(),
            "command_path": self.command_path, "failing_tasks": failing(),
            "holder": self.lease.holder if self.lease is not None else None,
            "failed_subscriptions": dict(self.failed_subscriptions),
            "connecting_until": self.connecting_until,
            "responding": self.responding, "heard_at": self.heard_at, "ros": self.ros_version,
        }

    async def set_command_path(self, ok: bool) -> None:
        """What the last ping over the request channel found, published every time: a store
        that came back empty from an outage has the link's status again within a second."""
        if ok != self.command_path:
            (log.info if ok else log.error)("command path %s", "answers again" if ok else "DOWN: a ping got no answer")
            self.command_path = ok
        await self.publish_status()

    async def publish_status(self) -> None:
        status = self.status()
        try:
            await aannounce_status({**status, "uplink": uplink_status()}, store=self.store)
        except Exception:
            log.exception("could not publish link status")

    async def _heartbeat(self) -> None:
        while not self._stopped:
            await asyncio.sleep(LINK_HEARTBEAT_S)
            # Failed connection attempts emit no "close"; count them from the factory.
            if self.ros is not None and not self.connected:
                self.attempts = max(self.attempts, getattr(self.ros.factory, "retries", 0))
            await self._sync_latch()
            await self.publish_status()

    async def _sync_latch(self) -> None:
        """Follow the shared latch; if the store lost it (Redis restarted empty) while this link
        holds a stop, write it back: a latch ends only by an operator's release."""
        try:
            entry = (await self.store.aget_many([LATCH_KEY])).get(LATCH_KEY)
            if self.guard is None:
                return
            if entry is not None:
                self._latch_msg = dict(entry.get("msg") or {})
            # A stop or release this link took moments ago may not be in the store yet: reading
            # the store then would undo it, or write back a latch without who and when.
            if not self.guard.settled(LATCH_SETTLE_S):
                return
            stored = Latch.from_msg(self._latch_msg if entry is not None else None)
            if self.guard.latched and self._pressed_at > max(stored.at, stored.released_at) and not stored.latched:
                log.warning("the shared store missed an E-STOP this link took: writing it")
                pressed = Latch(latched=True, by=self._pressed_by, at=self._pressed_at)
                await aannounce(LATCH_KEY, dict(server_update(LATCH_KEY, pressed.as_msg())), store=self.store)
            elif entry is not None:
                self.guard.sync(bool(self._latch_msg.get("latched")))
            elif self.guard.latched:
                log.warning("the shared store lost the E-STOP latch: writing it back")
                msg = self._latch_msg if self._latch_msg.get("latched") else {"latched": True}
                await aannounce(LATCH_KEY, dict(server_update(LATCH_KEY, msg)), store=self.store)
        except Exception:
            log.exception("could not read the E-STOP latch")

    async def _watch_port(self) -> None:
        """While disconnected, try again the moment rosbridge's port listens (not after the backoff)."""
        parts = urlsplit(self.url)
        host, port = parts.hostname or "127.0.0.1", parts.port or (443 if parts.scheme == "wss" else 80)
        while not self._stopped:
            await asyncio.sleep(PORT_WATCH_S)
            if self.connected or self.ros is None:
                continue
            try:
                _, writer = await asyncio.wait_for(asyncio.open_connection(host, port), PORT_WATCH_S * 2)
            except (OSError, TimeoutError):
                continue
            writer.close()
            if not self.connected:
                log.info("rosbridge's port %s:%d is listening again; reconnecting now", host, port)
                self.reconnect(keep_open=True)
                await asyncio.sleep(1)  # give the handshake time before looking again

    def reconnect(self, *, keep_open: bool = False) -> None:
        """Try now instead of waiting out the backoff (the page's reconnect button).

        With ``keep_open`` a connection that is open (or opening) stays as it is.
        """
        from twisted.internet import reactor

        ros = self.ros
        if ros is None:
            return

        def _now() -> None:
            factory = ros.factory
            proto = getattr(factory, "_proto", None)
            connecting = factory.connector is not None and factory.connector.state != "disconnected"
            if keep_open and (proto is not None or connecting):
                return
            # Cancel the backoff's pending retry before resetDelay(), which forgets it without
            # cancelling: it would fire while this connection is up ("can't connect in this state").
            call = getattr(factory, "_callID", None)
            if call is not None and call.active():
                call.cancel()
            factory.resetDelay()
            if proto is not None:
                proto.dropConnection(abort=True)  # the factory reconnects at once
            elif factory.connector is not None and factory.connector.state == "disconnected":
                factory.connector.connect()

        reactor.callFromThread(_now)
