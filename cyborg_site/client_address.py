"""Each connection's client address, the one its lockouts, throttles and audit entries count.

A request that comes from a trusted proxy (``TRUSTED_PROXIES``: addresses or networks) is taken
to be for the last address of its ``X-Forwarded-For`` (the one that proxy added; the shipped
nginx sets only the client's own) and for the scheme of its ``X-Forwarded-Proto``. From anyone
else those headers are ignored, so a client cannot name its own address. The ASGI scope's
``client`` and ``scheme`` are rewritten here, in front of everything, so every path (the fast
paths, Django's ``REMOTE_ADDR``, django-axes, the websocket consumers) sees the same address.
"""

from __future__ import annotations

import ipaddress
from contextvars import ContextVar
from functools import lru_cache
from typing import Any

from django.conf import settings

Network = ipaddress.IPv4Network | ipaddress.IPv6Network
# The client of the request or socket being served (set for each connection, below): the audit's.
client_address: ContextVar[str] = ContextVar("client_address", default="")


@lru_cache(maxsize=4)
def _networks(entries: tuple[str, ...]) -> tuple[Network, ...]:
    return tuple(ipaddress.ip_network(entry, strict=False) for entry in entries)


def is_trusted_proxy(address: str) -> bool:
    networks = _networks(tuple(settings.TRUSTED_PROXIES))
    if not networks or not address:
        return False
    try:
        ip = ipaddress.ip_address(address)
    except ValueError:
        return False
    return any(ip in network for network in networks)


def _header(scope: dict[str, Any], name: bytes) -> str:
    for key, value in scope.get("headers") or ():
        if key == name:
            return bytes(value).decode("latin-1")
    return ""


def behind_proxy(scope: dict[str, Any]) -> dict[str, Any]:
    """``scope`` with the client and scheme a trusted proxy vouches for (the same scope otherwise)."""
    peer = str((scope.get("client") or ("",))[0] or "")
    if not is_trusted_proxy(peer):
        return scope
    forwarded = [part.strip() for part in _header(scope, b"x-forwarded-for").split(",")]
    changed = dict(scope)
    if forwarded[-1]:
        changed["client"] = (forwarded[-1], 0)
    proto = _header(scope, b"x-forwarded-proto").strip().lower()
    if proto in ("http", "https"):
        secure = proto == "https"
        changed["scheme"] = ("wss" if secure else "ws") if scope["type"] == "websocket" else proto
    return changed


class ClientAddress:
    def __init__(self, app: Any) -> None:
        self.app = app

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        scope = behind_proxy(scope)
        client = scope.get("client") or ("",)
        token = client_address.set(str(client[0] or ""))
        try:
            await self.app(scope, receive, send)
        finally:
            client_address.reset(token)
