"""The second path to the link, for what stops the robot: no Redis, no channel layer.

Scaled, web processes reach the link through Redis; a stop must not depend on it. So the active
link also listens on a TCP address of its own (``ROBOT_LINK_DIRECT_ADDRESSES``: one per link
process, each binds the first one free) and takes the E-STOP's own requests (marked ``emergency``,
``robot.link.bus.emergency``). A web process sends those to every address at once and takes the
answer of the link that is active (a standby listens too, and only stops the robot:
``robot.link.standby``). One request
per connection: a line of JSON signed with the secret key (``django.core.signing``, valid for a few
seconds), answered by a line of JSON.
"""

from __future__ import annotations

import asyncio
import json
import logging
from typing import Any, cast

from django.conf import settings
from django.core import signing

from robot.live.groups import LinkReply, LinkRequest
from robot.supervisor import spawn

log = logging.getLogger(__name__)

SALT = "robot.link.direct"
MAX_AGE_S = 10
CONNECT_TIMEOUT_S = 0.3
ACTIVE_GRACE_S = 0.15  # after a standby stopped the robot, how long the active link's answer is waited for
LINE_LIMIT = 256 * 1024


class Unreachable(Exception):
    """No link answered on the direct path (none listens, or none is active)."""


def addresses() -> list[tuple[str, int]]:
    parts = [item.rpartition(":") for item in settings.ROBOT_LINK_DIRECT_ADDRESSES]
    return [(host or "127.0.0.1", int(port)) for host, _, port in parts]


def enabled() -> bool:
    return bool(settings.ROBOT_LINK_DIRECT_ADDRESSES) and not settings.EMBEDDED


# --- the link's side ----------------------------------------------------------------------


async def serve(execute: Any) -> None:
    """Listen on the first free address and answer stopping requests with ``execute(request)``;
    runs until cancelled (the link stops)."""
    server = None
    for host, port in addresses():
        try:
            server = await asyncio.start_server(lambda r, w: _answer(r, w, execute), host, port, limit=LINE_LIMIT)
        except OSError:
            continue
        log.info("robot link: direct stop path on %s:%d", host, port)
        break
    if server is None:
        raise OSError(f"none of ROBOT_LINK_DIRECT_ADDRESSES is free here: {settings.ROBOT_LINK_DIRECT_ADDRESSES}")
    async with server:
        await server.serve_forever()


async def _answer(reader: asyncio.StreamReader, writer: asyncio.StreamWriter, execute: Any) -> None:
    try:
        line = await asyncio.wait_for(reader.readline(), 2)
        reply: LinkReply
        try:
            request = cast(LinkRequest, signing.loads(line.decode().strip(), salt=SALT, max_age=MAX_AGE_S))
        except (signing.BadSignature, UnicodeDecodeError):
            reply = {"ok": False, "error_code": "forbidden", "error": "bad or expired signature"}
        else:
            if request.get("op") != "estop" and not request.get("emergency"):
                reply = {"ok": False, "error_code": "invalid", "error": "only what stops the robot comes this way"}
            else:
                late: LinkReply = {"ok": False, "error_code": "timeout", "error": "arrived too late"}
                reply = await execute(request) or late
        writer.write(json.dumps(reply, default=str).encode() + b"\n")
        await writer.drain()
    except (OSError, TimeoutError, ValueError):
        log.debug("direct stop path: a request went unanswered", exc_info=True)
    finally:
        writer.close()


# --- a web process's side -----------------------------------------------------------------


async def ask(request: LinkRequest, timeout: float) -> LinkReply:
    """Send ``request`` to every link address; the reply of the active link (the first that is not
    "offline"); else, ``ACTIVE_GRACE_S`` after a standby stopped the robot, the standby's; else the
    last refusal; ``Unreachable`` if no link listens."""
    line = signing.dumps(dict(request), salt=SALT, compress=True).encode() + b"\n"
    pending = {spawn(_one(host, port, line, timeout), awaited=True) for host, port in addresses()}
    loop = asyncio.get_running_loop()
    standby: LinkReply | None = None
    refusal: LinkReply | None = None
    grace_end = 0.0
    try:
        while pending:
            wait = None if standby is None else max(0.0, grace_end - loop.time())
            done, pending = await asyncio.wait(pending, timeout=wait, return_when=asyncio.FIRST_COMPLETED)
            if not done:
                break  # the active link did not answer within the grace: the standby stopped the robot
            for task in done:
                reply = None if task.exception() else task.result()
                if reply is None:
                    continue
                if reply.get("standby"):
                    if reply.get("ok") and standby is None:
                        standby, grace_end = reply, loop.time() + ACTIVE_GRACE_S
                    refusal = refusal or reply
                elif reply.get("ok") or reply.get("error_code") != "offline":
                    return reply
                else:
                    refusal = reply
    finally:
        for task in pending:
            task.cancel()
    if standby is not None:
        return standby
    if refusal is not None:
        return refusal
    raise Unreachable("no robot link answered on the direct stop path")


async def _one(host: str, port: int, line: bytes, timeout: float) -> LinkReply | None:
    try:
        reader, writer = await asyncio.wait_for(asyncio.open_connection(host, port, limit=LINE_LIMIT),
                                                CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError):
        return None
    try:
        writer.write(line)
        await writer.drain()
        answer = await asyncio.wait_for(reader.readline(), timeout)
        return cast(LinkReply, json.loads(answer)) if answer else None
    finally:
        writer.close()
