"""``GET /api/robot/state/`` for a recently seen token, answered on the event loop.

Scripts poll the state. Through Django that costs the ASGI handler's thread hops (its middleware
chain runs in a thread, the synchronous DRF view crosses back to the loop for the store), the
whole middleware chain and DRF's machinery, for a read of the in-memory or Redis store.

``FastStateApp`` sits in front of Django's ASGI application and answers exactly one kind of request
itself: ``GET`` on the state path, no query string, an ``Authorization: Token`` header whose token
the per-process cache (robot.api.tokens) already trusts, JSON acceptable. The answer is the view's:
the same data (``arobot_state``), the same renderer, and the response headers the site's middleware
would add (host check, security headers, frame options), worked out through Django's request and
middleware once per combination of what they read, and sent as two ASGI messages with no Django
request or response per call. Anything else, and every token the cache does not know yet, goes to
Django unchanged: that is where a token is checked against the database (and cached), where errors
get the API's error shape, and where the browsable API and sessions live.
"""

from __future__ import annotations

import io
from typing import Any

from django.conf import settings
from django.core.exceptions import DisallowedHost
from django.core.handlers.asgi import ASGIHandler, ASGIRequest
from django.core.signals import setting_changed
from django.http import HttpResponse
from django.middleware.clickjacking import XFrameOptionsMiddleware
from django.middleware.security import SecurityMiddleware

from cyborg_site import csp
from robot.api.errors import SafeJSONRenderer
from robot.api.tokens import CachedTokenAuthentication
from robot.commands.selectors import arobot_state

STATE_PATH = "/api/robot/state/"
JSON_ACCEPT = frozenset({"", "*/*", "application/json", "application/*"})
# The request headers the host check and the security middleware read (besides scheme and server).
_CHECKED_HEADERS = frozenset({b"host", b"x-forwarded-host", b"x-forwarded-port", b"x-forwarded-proto"})
_CHECKS_KEPT = 64

Headers = list[tuple[bytes, bytes]]


def _never_called(request: Any) -> HttpResponse:
    raise AssertionError("the fast path builds its own response")


class SiteChecks:
    """What the site's middleware does for a request answered outside Django: the host check, the
    HTTPS redirect (either means Django must answer) and the response headers it adds."""

    def __init__(self) -> None:
        self._security = SecurityMiddleware(_never_called)
        self._frames = XFrameOptionsMiddleware(_never_called)

    def request(self, scope: dict[str, Any]) -> ASGIRequest | None:
        """A bodiless request for ``scope``, or None when Django must answer (bad host, a redirect)."""
        request = ASGIRequest(scope, io.BytesIO())
        try:
            request.get_host()  # ALLOWED_HOSTS, as CommonMiddleware checks it
        except DisallowedHost:
            return None
        if self._security.process_request(request) is not None:  # an HTTPS redirect
            return None
        return request

    def finish(self, request: ASGIRequest, response: HttpResponse) -> HttpResponse:
        self._frames.process_response(request, response)
        response["Content-Length"] = str(len(response.content))  # where CommonMiddleware sets it
        response.headers.setdefault(csp.HEADER, csp.DEFAULT)  # as cyborg_site.csp's middleware does
        return self._security.process_response(request, response)


def json_accepted(accept: bytes) -> bool:
    return accept.split(b";", 1)[0].strip().decode("latin1") in JSON_ACCEPT


def _token_key(authorization: bytes) -> str | None:
    scheme, _, key = authorization.decode("latin1").partition(" ")
    return key.strip() if scheme.lower() == "token" else None


async def token_user(authorization: bytes) -> Any:
    """The user of an ``Authorization: Token`` header the token cache trusts, else None; a known token
    whose trust ran out is renewed first (one query, shared by the requests that wait for it). The
    user it answers is the one to judge by: on a busy loop the renewed trust may run out again before
    the next look."""
    key = _token_key(authorization)
    if key is None:
        return None
    return CachedTokenAuthentication.cached_user(key) or await CachedTokenAuthentication.arenew(key)


class FastStateApp:
    """ASGI: the state of a cached token's caller, without Django's handler; the rest to ``django_app``."""

    def __init__(self, django_app: ASGIHandler) -> None:
        self.django_app = django_app
        self._renderer = SafeJSONRenderer()
        self._site = SiteChecks()
        # The host check and the response headers depend only on a few request headers, the scheme and
        # the server address, and on settings: worked out once per combination (a poller sends the same
        # ones every time), through Django's own request, middleware and response.
        self._checked: dict[tuple[Any, ...], tuple[Headers, Headers] | None] = {}
        self._proxy_ssl_header = _proxy_ssl_header()
        setting_changed.connect(self._forget_checks)

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] == "http" and scope["path"] == STATE_PATH and scope["method"] == "GET":
            headers = await self.response_headers(scope)
            if headers is not None:
                body = self._renderer.render(await arobot_state())
                before, after = headers
                await send({"type": "http.response.start", "status": 200,
                            "headers": [*before, (b"Content-Length", str(len(body)).encode()), *after]})
                await send({"type": "http.response.body", "body": body})
                return
        await self.django_app(scope, receive, send)

    async def response_headers(self, scope: dict[str, Any]) -> tuple[Headers, Headers] | None:
        """The answer's headers before and after Content-Length, or None when Django must answer
        (unknown token, other formats, bad host, an HTTPS redirect…)."""
        if scope.get("query_string") or scope.get("root_path"):
            return None
        authorization = accept = b""
        checked = []
        proxy_ssl_header = self._proxy_ssl_header
        for name, value in scope["headers"]:
            if name == b"authorization":
                authorization = value
            elif name == b"accept":
                accept = value
            elif name in _CHECKED_HEADERS or name == proxy_ssl_header:
                checked.append((name, value))
        if not json_accepted(accept) or await token_user(authorization) is None:
            return None
        check = (scope.get("scheme"), tuple(scope.get("server") or ()), tuple(checked))
        if check not in self._checked:
            if len(self._checked) >= _CHECKS_KEPT:  # hosts that vary per request (hostile ones) only cost a check
                self._checked.clear()
            self._checked[check] = self._check(scope)
        return self._checked[check]

    def _check(self, scope: dict[str, Any]) -> tuple[Headers, Headers] | None:
        request = self._site.request(scope)
        if request is None:
            return None
        response = HttpResponse(content_type="application/json")
        response["Vary"] = "Accept"
        response["Allow"] = "GET, HEAD, OPTIONS"
        response = self._site.finish(request, response)
        headers = [(name.encode("ascii"), value.encode("latin1")) for name, value in response.items()]
        at = [name for name, _ in headers].index(b"Content-Length")  # each answer's own length goes there
        return headers[:at], headers[at + 1:]

    def _forget_checks(self, **kwargs: Any) -> None:
        self._checked.clear()
        self._proxy_ssl_header = _proxy_ssl_header()


def _proxy_ssl_header() -> bytes:
    """The ASGI name of the header ``SECURE_PROXY_SSL_HEADER`` names (it decides ``is_secure``)."""
    header = settings.SECURE_PROXY_SSL_HEADER
    return header[0].removeprefix("HTTP_").replace("_", "-").lower().encode("latin1") if header else b""
