"""The websocket origin check, the same rule as Django's CSRF origin check.

A browser opens a websocket with the page's cookies whatever page it is on, so a socket is
accepted only from the site itself (scheme, host and port of the request) or from an entry
of ``CSRF_TRUSTED_ORIGINS`` (``https://*.example.com`` covers subdomains), with the Host
validated against ``ALLOWED_HOSTS``. Behind a TLS proxy, ``SECURE_PROXY_SSL_HEADER`` says
the site is https, or the proxy's origin is listed in ``CSRF_TRUSTED_ORIGINS``.
"""

from __future__ import annotations

from typing import Any
from urllib.parse import urlsplit

from channels.security.websocket import WebsocketDenier
from django.conf import settings
from django.http.request import split_domain_port, validate_host
from django.utils.http import is_same_domain


def _header(scope: dict[str, Any], name: str) -> str | None:
    wanted = name.lower().encode("latin1")
    for key, value in scope.get("headers", ()):
        if key.lower() == wanted:
            return value.decode("latin1")
    return None


def _is_secure(scope: dict[str, Any]) -> bool:
    proxy = getattr(settings, "SECURE_PROXY_SSL_HEADER", None)
    if proxy:
        header, secure_value = proxy
        name = header.removeprefix("HTTP_").replace("_", "-")
        value = _header(scope, name)
        if value is not None:
            return value.split(",", 1)[0].strip() == secure_value
    return scope.get("scheme") in ("wss", "https")


def _site_origin(scope: dict[str, Any]) -> str | None:
    host = _header(scope, "host")
    if not host:
        return None
    domain, _port = split_domain_port(host)
    if not domain or not validate_host(domain, settings.ALLOWED_HOSTS):
        return None
    return f"{'https' if _is_secure(scope) else 'http'}://{host}"


def origin_allowed(origin: str | None, scope: dict[str, Any]) -> bool:
    if not origin:
        return False
    if origin == _site_origin(scope):
        return True
    trusted = list(settings.CSRF_TRUSTED_ORIGINS)
    if origin in trusted:
        return True
    try:
        parts = urlsplit(origin)
    except ValueError:
        return False
    wildcards = [urlsplit(t) for t in trusted if "*" in t]
    return any(w.scheme == parts.scheme and is_same_domain(parts.netloc, w.netloc.lstrip("*")) for w in wildcards)


class OriginCheck:
    """ASGI middleware: refuse the websocket handshake (403) from any other origin.

    On ``ticket_paths`` (the front door for ROS tools) a socket without an Origin is a tool, not a
    browser, and its single-use ticket is what lets it in; a browser's Origin must still be the site's
    or one of ``FRONTDOOR_ORIGINS`` (a Foxglove web app, a roslibjs page elsewhere)."""

    def __init__(self, application: Any, *, ticket_paths: tuple[str, ...] = ()) -> None:
        self.application = application
        self.ticket_paths = ticket_paths

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> Any:
        if scope["type"] == "websocket" and not self._allowed(scope):
            return await WebsocketDenier()(scope, receive, send)
        return await self.application(scope, receive, send)

    def _allowed(self, scope: dict[str, Any]) -> bool:
        origin = _header(scope, "origin")
        if scope.get("path") in self.ticket_paths:
            return origin is None or origin in settings.FRONTDOOR_ORIGINS or origin_allowed(origin, scope)
        return origin_allowed(origin, scope)
