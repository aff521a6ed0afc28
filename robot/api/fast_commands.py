"""The API's one-field commands (``robot.api.commands``) for a recently seen token, answered on the
event loop.

Through Django a command costs, before anything reaches the robot, a new thread per request
(the handler's ``ThreadSensitiveContext``), the middleware chain, DRF's dispatch and a hop back to
the loop for the publish; after it, the audit row through a new database connection. Here, for a
caller whose token the per-process cache trusts and whose roles it already read (both from an
earlier request through Django), the command is answered on the loop with the view's own parts:
DRF's throttle (same classes, same cache), the same parser, body checks and command builder, the
pipeline's asynchronous face (role check, input check, send, audit row on the audit writer's
thread) and the API's error handler and renderer, so the status codes and bodies are the view's.
The response waits for the audit row, as the view's did.

Everything else goes to Django unchanged, with the body if it was read: other content types, the
browsable API, unknown tokens, users whose roles are not cached yet, commands whose check reads
the database (presets, modes), bodies over the upload limit.
"""

from __future__ import annotations

import io
import logging
from functools import lru_cache
from typing import Any

from django.conf import settings
from django.core.handlers.asgi import ASGIHandler, ASGIRequest
from django.http import HttpResponse
from django.urls import Resolver404, resolve
from django.utils.cache import patch_vary_headers
from rest_framework.exceptions import APIException
from rest_framework.request import Request

from cyborg_site.roles import roles_cached
from robot.api.commands import FieldCommandView
from robot.api.errors import BoundedJSONParser, SafeJSONRenderer, api_exception_handler, api_server_error
from robot.api.fast_state import SiteChecks, json_accepted, token_user
from robot.api.validation import body_dict, reject_unknown
from robot.commands.pipeline import Command, arun

log = logging.getLogger(__name__)

_PARSER_CONTEXT = {"encoding": "utf-8"}


@lru_cache(maxsize=256)
def command_view(path: str) -> type[FieldCommandView] | None:
    try:
        match = resolve(path)
    except Resolver404:
        return None
    view = getattr(match.func, "view_class", None)
    return view if isinstance(view, type) and issubclass(view, FieldCommandView) else None


def _headers(scope: dict[str, Any]) -> dict[bytes, bytes]:
    return {name: value for name, value in scope["headers"]
            if name in (b"authorization", b"accept", b"content-type", b"content-length")}


def _declared_length(value: bytes | None) -> int | None:
    if value is None or not value.isdigit():
        return None
    length = int(value)
    limit = settings.DATA_UPLOAD_MAX_MEMORY_SIZE
    return length if limit is None or length <= limit else None


class FastCommandApp:
    """ASGI: a trusted caller's one-field command, without Django's handler; the rest to ``app``."""

    def __init__(self, app: Any, handler: ASGIHandler) -> None:
        self.app = app
        self.handler = handler  # for ``send_response``
        self._renderer = SafeJSONRenderer()
        self._site = SiteChecks()

    async def __call__(self, scope: dict[str, Any], receive: Any, send: Any) -> None:
        if scope["type"] == "http" and scope["method"] == "POST" and scope["path"].startswith("/api/robot/"):
            view = command_view(scope["path"])  # (never the E-STOP: it must not wait on the database)
            caller = None if view is None else await self.eligible(scope, view)
            if caller is not None:
                body, more = await _read(receive, caller[3])
                if body is None:
                    return  # the client went away
                whole = not more and len(body) == caller[3]
                response = await self.answer(*caller[:3], body) if whole else None
                if response is not None:
                    await self.handler.send_response(response, send)
                    return
                receive = _replay(body, more, receive)
        await self.app(scope, receive, send)

    async def eligible(self, scope: dict[str, Any], view: type[FieldCommandView],
                       ) -> tuple[type[FieldCommandView], Any, ASGIRequest, int] | None:
        """(view, user, request, body length) when this app may answer, judged on the headers alone."""
        if scope.get("query_string") or scope.get("root_path"):
            return None
        headers = _headers(scope)
        content_type = headers.get(b"content-type", b"").strip().lower()
        length = _declared_length(headers.get(b"content-length"))
        if content_type != b"application/json" or length is None or not json_accepted(headers.get(b"accept", b"")):
            return None
        user = await token_user(headers.get(b"authorization", b""))
        if user is None or not roles_cached(user):
            return None
        request = self._site.request(scope)
        return None if request is None else (view, user, request, length)

    async def answer(self, view_class: type[FieldCommandView], user: Any, request: ASGIRequest,
                     body: bytes) -> HttpResponse | None:
        """The view's response, or None when Django must answer (a check that reads the database)."""
        view = view_class()
        command: Command | None = None
        refused: APIException | None = None
        # Parsed before the throttle only to know who answers; as in DRF, the throttle is checked first.
        try:
            data = body_dict(BoundedJSONParser().parse(io.BytesIO(body), None, _PARSER_CONTEXT) if body else {})
            reject_unknown(data, [view_class.field])
            command = view_class.command(data.get(view_class.field), user)
        except APIException as exc:
            refused = exc
        if command is not None and not command.check_on_loop:
            return None
        try:
            throttled = Request(request)
            throttled.user = user
            view.check_throttles(throttled)
            if refused is not None:
                raise refused
            assert command is not None
            outcome = await arun(command, user=user, source="api")
            response = self._render(200, {"ok": True, "action": view_class.action_name, "outcome": outcome})
        except Exception as exc:
            handled = api_exception_handler(exc, {"view": view})
            if handled is None:
                log.exception("API command %s failed", request.path)
                return self._site.finish(request, api_server_error(exc))
            response = self._render(handled.status_code, handled.data)
            for name, value in handled.headers.items():
                if name.lower() != "content-type":
                    response[name] = value
        for name, value in view.default_response_headers.items():
            if name == "Vary":
                patch_vary_headers(response, [value])
            else:
                response[name] = value
        return self._site.finish(request, response)

    def _render(self, status: int, data: Any) -> HttpResponse:
        return HttpResponse(self._renderer.render(data), status=status, content_type="application/json")


async def _read(receive: Any, length: int) -> tuple[bytes | None, bool]:
    """The body as far as its declared length (or the end, if sooner), and whether more follows."""
    chunks: list[bytes] = []
    size = 0
    while True:
        message = await receive()
        if message["type"] == "http.disconnect":
            return None, False
        chunk = message.get("body", b"")
        chunks.append(chunk)
        size += len(chunk)
        more = bool(message.get("more_body"))
        if not more or size > length:
            return b"".join(chunks), more


def _replay(body: bytes, more: bool, receive: Any) -> Any:
    """``receive`` for Django, starting with the part of the body already read."""
    pending = [{"type": "http.request", "body": body, "more_body": more}]

    async def replayed() -> dict[str, Any]:
        return pending.pop() if pending else await receive()

    return replayed
