"""Where the robot's uplink agent connects (nginx passes ``/uplink/`` here).

An agent shows its credential in the handshake's ``Authorization: Bearer`` header; anything else
gets a bare 403 and an audit row (a flood from one address: a bare 429 without a look, audited
once). One uplink per robot: a second agent with a good credential **takes over**, and the first is
closed (audited). Refusing it instead would lock a restarted agent out until the server noticed
the old connection was dead (a robot whose Wi-Fi dropped leaves a half-open connection for as
long as the pings take to fail), and a thief with the credential can do worse than take over.
While the uplink is open its credential is looked at every ``RECHECK_S``: revoked or rotated, the
connection closes at once.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import logging
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

from django.db import connection
from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response

from cyborg_site.bucket import Bucket
from cyborg_site.client_address import is_trusted_proxy
from robot.link.status import HostedUplink
from robot.supervisor import Tasks
from robot.uplink import credentials
from robot.uplink.limits import Attempts
from robot.uplink.relays import Relays
from robot.uplink.status import clock
from robot.uplink.tunnel import Tunnel
from uplink_agent import mux

log = logging.getLogger(__name__)

RECHECK_S = 0.25
PING_INTERVAL_S = 5.0
PING_TIMEOUT_S = 10.0
CLOSE_TIMEOUT_S = 2.0  # an agent that does not answer our close is cut off after this
# Close codes the agent sees (and the audit names).
TAKEN_OVER, REVOKED, TOO_FAST, NOT_UPLINK = 4000, 4001, 4002, 4003


# The endpoint's own database thread: asgiref's one shared thread may be busy with another service's
# long call, and a revocation must be seen within a second.
_db = ThreadPoolExecutor(max_workers=1, thread_name_prefix="uplink-db")


def _fresh[T](fn: Callable[..., T], **kwargs: Any) -> T:
    connection.close_if_unusable_or_obsolete()  # a database restarted since the last call
    return fn(**kwargs)


def _close_connection() -> None:
    connection.close()  # (the connection of the thread this runs in)


async def in_db[T](fn: Callable[..., T], **kwargs: Any) -> T:
    return await asyncio.get_running_loop().run_in_executor(_db, functools.partial(_fresh, fn, **kwargs))


@dataclass
class Live:
    connection: ServerConnection
    accepted: credentials.Accepted
    address: str
    since: float
    tunnel: Tunnel
    ending: str = ""  # why the server closes it, for the audit
    tasks: Tasks = field(default_factory=Tasks)


async def _audit(action: str, *, ok: bool, address: str, outcome: str, params: dict[str, Any]) -> None:
    from robot.commands.audit_writer import writer

    try:
        await writer.record(user=None, source="system", action=action, params=params, ok=ok, outcome=outcome,
                            address=address)
    except Exception:
        log.exception("could not audit %s from %s", action, address)


class UplinkEndpoint(HostedUplink):
    def __init__(self, *, host: str, port: int, robot: str, relays: Relays, max_frame_bytes: int,
                 max_messages_per_s: int, auth_timeout_s: float, failure_limit: int) -> None:
        self.host, self.port, self.robot = host, port, robot
        self.relays = relays
        self.max_frame_bytes = max_frame_bytes
        self.max_messages_per_s = max_messages_per_s
        self.auth_timeout_s = auth_timeout_s
        self.attempts = Attempts(failure_limit)
        self.live: Live | None = None
        self.last_end: dict[str, Any] = {}
        self._accepted: dict[ServerConnection, tuple[credentials.Accepted, str]] = {}
        self._turn = asyncio.Lock()  # one uplink at a time: a take-over ends the old one before the new starts
        self._server: Server | None = None

    def status(self) -> dict[str, Any]:
        """What health and the pages tell: from where and since when, or why not."""
        live = self.live
        if live is not None:
            return {"connected": True, "address": live.address, "since": live.since, "robot": self.robot}
        return {"connected": False, "robot": self.robot, **self.last_end}

    async def start(self) -> None:
        self._server = await serve(
            self._serve, self.host, self.port, process_request=self._authenticate,
            max_size=self.max_frame_bytes, open_timeout=self.auth_timeout_s, compression=None,
            ping_interval=PING_INTERVAL_S, ping_timeout=PING_TIMEOUT_S, close_timeout=CLOSE_TIMEOUT_S,
            server_header=None)
        log.info("uplink endpoint listening on %s:%d for robot %r", self.host, self.port, self.robot)

    async def stop(self) -> None:
        if self._server is not None:
            self._server.close()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._server.wait_closed(), 3)
            self._server = None
        await self.relays.stop()
        with contextlib.suppress(Exception):  # its database thread's connection goes with it
            await asyncio.wait_for(asyncio.get_running_loop().run_in_executor(_db, _close_connection), 2)

    def _address(self, connection: ServerConnection, request: Request) -> str:
        peer = str((connection.remote_address or ("",))[0])
        if is_trusted_proxy(peer):
            forwarded = request.headers.get("X-Forwarded-For", "").split(",")[-1].strip()
            return forwarded or peer
        return peer

    async def _authenticate(self, connection: ServerConnection, request: Request) -> Response | None:
        address = self._address(connection, request)
        params = {"robot": self.robot}
        if self.attempts.blocked(address):
            return connection.respond(429, "")
        header = request.headers.get("Authorization", "")
        accepted = None
        if header.startswith("Bearer "):
            accepted = await in_db(credentials.credential_check, text=header[7:].strip(), robot=self.robot)
        if accepted is None:
            blocking = self.attempts.refused(address)
            outcome = "refused: no valid credential" + ("; this address is refused for a minute" if blocking else "")
            log.warning("uplink from %s %s", address, outcome)
            await _audit("uplink.refuse", ok=False, address=address, outcome=outcome, params=params)
            return connection.respond(403, "")
        self._accepted[connection] = (accepted, address)
        return None

    async def _serve(self, connection: ServerConnection) -> None:
        accepted, address = self._accepted.pop(connection)
        params = {"robot": self.robot, "credential": accepted.key_id}
        async with self._turn:
            old = self.live
            if old is not None:
                old.ending = f"taken over by {address}"
                await self._end(old)
                await _audit("uplink.takeover", ok=True, address=address, params=params,
                             outcome=f"took over from {old.address} (connected since {clock(old.since)})")
            live = self.live = Live(connection, accepted, address, time.time(), Tunnel(connection))
            await self.relays.start(live.tunnel)
        log.info("robot %s connected through its uplink from %s", self.robot, address)
        await _audit("uplink.connect", ok=True, address=address, outcome="connected", params=params)
        await in_db(credentials.credential_note_use, accepted=accepted, address=address)
        live.tasks.start(self._watch_credential(live))
        try:
            await self._carry(live)
        except ConnectionClosed:
            pass
        finally:
            async with self._turn:
                if self.live is live:
                    await self._end(live)
            why = live.ending or _close_text(connection)
            log.info("robot %s's uplink from %s closed: %s", self.robot, address, why)
            await _audit("uplink.disconnect", ok=True, address=address, outcome=why, params=params)

    async def _carry(self, live: Live) -> None:
        rate = self.max_messages_per_s  # with a second's worth of burst
        bucket = Bucket(rate, rate)
        async for message in live.connection:
            if bucket.take():
                await self._close(live, TOO_FAST, f"over {self.max_messages_per_s} messages a second")
                return
            if isinstance(message, str):
                await self._close(live, NOT_UPLINK, "a text frame on the uplink")
                return
            try:
                live.tunnel.dispatch(message)
            except mux.BadFrame as exc:
                await self._close(live, NOT_UPLINK, str(exc))
                return

    async def _close(self, live: Live, code: int, why: str) -> None:
        live.ending = live.ending or why
        await live.connection.close(code, why[:120])

    async def _end(self, live: Live) -> None:
        """The uplink's relays and channels go (its connection, if still open, too)."""
        self.live = None
        self.last_end = {"last_address": live.address, "last_since": live.since, "ended": time.time(),
                         "why": live.ending or _close_text(live.connection)}
        live.tasks.cancel()
        live.tunnel.end()
        await self.relays.stop()
        code = TAKEN_OVER if live.ending.startswith("taken over") else 1000
        with contextlib.suppress(Exception):
            await asyncio.wait_for(live.connection.close(code, live.ending[:120]), 1)

    async def _watch_credential(self, live: Live) -> None:
        while True:
            await asyncio.sleep(RECHECK_S)
            try:
                good = await in_db(credentials.credential_still_good, accepted=live.accepted)
            except Exception:
                log.warning("could not look at the uplink's credential; looking again", exc_info=True)
                continue
            if not good:
                log.warning("the uplink's credential was revoked or rotated: closing its connection")
                await self._close(live, REVOKED, "credential revoked or rotated")
                return


def _close_text(connection: ServerConnection) -> str:
    code = connection.close_code
    if code is None:
        return "connection lost"
    return f"closed ({code}{': ' + connection.close_reason if connection.close_reason else ''})"
