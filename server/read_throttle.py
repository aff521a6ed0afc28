"""Reads are throttled per caller, so a page or script that polls hard cannot starve commands.

In front of every HTTP app: a ``GET``/``HEAD`` takes a token from its caller's bucket (``READ_THROTTLE_PER_S``,
bursts of ``READ_THROTTLE_BURST``); without one it waits for the next, and past ``READ_THROTTLE_WAIT_S`` it gets
429 after that wait. Waiting, not refusing at once: a client that asks again as soon as it is answered (most
scripts, every load tool) is slowed to the rate instead of flooding the process with refusals. The caller is
the API token, else the session cookie, else the client's address; nothing is read from a database or Redis
(a stop must not wait on them), so each web process keeps its own buckets. Static files and health are exempt.
"""

from __future__ import annotations

import asyncio
import hashlib
import json
from functools import lru_cache
from typing import Any

from django.conf import settings

from cyborg_site.bucket import Bucket

EXEMPT_PREFIXES = ("/static/", "/healthz")
KEPT_CALLERS = 10_000


def caller(scope: dict[str, Any]) -> str:
    headers = dict(scope.get("headers") or [])
    auth = headers.get(b"authorization", b"")
    if auth[:6].lower() == b"token ":
        return "token:" + hashlib.sha256(auth[6:].strip()).hexdigest()
    for part in headers.get(b"cookie", b"").split(b";"):
        name, _, value = part.strip().partition(b"=")
        if name == settings.SESSION_COOKIE_NAME.encode() and value:
            return "session:" + hashlib.sha256(value).hexdigest()
    return "address:" + str((scope.get("client") or ("",))[0])


class ReadThrottle:
    def __init__(self, app: Any) -> None:
        self.app = app
        # A bucket per caller; past KEPT_CALLERS the least recently seen is forgotten.
        self._bucket = lru_cache(maxsize=KEPT_CALLERS)(
            lambda key: Bucket(settings.READ_THROTTLE_PER_S, settings.READ_THROTTLE_BURST))

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        rate = settings.READ_THROTTLE_PER_S
        if (scope["type"] != "http" or scope["method"] not in ("GET", "HEAD") or rate <= 0
                or scope["path"].startswith(EXEMPT_PREFIXES)):
            return await self.app(scope, receive, send)
        bucket = self._bucket(caller(scope))
        wait = bucket.take()
        if wait > settings.READ_THROTTLE_WAIT_S:
            bucket.tokens += 1  # not served: the token goes back
            await asyncio.sleep(settings.READ_THROTTLE_WAIT_S)
            return await _too_many(send, wait - settings.READ_THROTTLE_WAIT_S)
        if wait:
            await asyncio.sleep(wait)
        await self.app(scope, receive, send)

async def _too_many(send: Any, retry_after: float) -> None:
    body = json.dumps({"detail": f"Too many reads: at most {settings.READ_THROTTLE_PER_S:g} per second; "
                                 "try again in a moment.", "code": "throttled"}).encode()
    await send({"type": "http.response.start", "status": 429, "headers": [
        (b"content-type", b"application/json"), (b"retry-after", str(max(1, round(retry_after))).encode()),
        (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})
