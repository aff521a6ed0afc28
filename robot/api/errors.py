"""One error shape for the whole API: {"detail": message, "code": code[, "field": name]}.

DRF views answer through ``api_exception_handler``; what fails before or outside DRF (an
unknown /api/ path, a body Django refuses, a crash) goes through the site's error handlers,
which call ``api_error`` for /api/ paths. Redis or the database being down is a 503
"service unavailable: …" everywhere, never a 500.
"""

from __future__ import annotations

from typing import Any

from django.conf import settings
from django.core.exceptions import RequestDataTooBig, SuspiciousOperation, TooManyFieldsSent
from django.db import InterfaceError, OperationalError
from django.http import JsonResponse
from redis.exceptions import ConnectionError as RedisConnectionError
from redis.exceptions import TimeoutError as RedisTimeout
from rest_framework import exceptions, status
from rest_framework.parsers import FormParser, JSONParser, MultiPartParser
from rest_framework.renderers import JSONRenderer
from rest_framework.response import Response
from rest_framework.views import exception_handler

from cyborg_site.text import character_problem, scrub, scrub_json
from robot.link.bus import RobotError

API_PREFIX = "/api/"
# Deeper JSON than this is refused as a whole (no API input nests beyond a few levels).
MAX_JSON_DEPTH = 32


def error_body(detail: str, code: str, field: str | None = None) -> dict[str, Any]:
    body: dict[str, Any] = {"detail": detail, "code": code}
    if field:
        body["field"] = field
    return body


def api_error(status_code: int, detail: str, code: str, field: str | None = None) -> JsonResponse:
    """The error shape outside DRF (site error handlers, middleware)."""
    return JsonResponse(error_body(detail, code, field), status=status_code)


def api_server_error(exc: BaseException | None) -> JsonResponse:
    """The API's answer to an exception nothing handled: 503 for a service that is down, else 500."""
    service = unavailable(exc) if exc else None
    if service:
        response = api_error(503, unavailable_detail(service), "unavailable")
        response["Retry-After"] = "5"
        return response
    return api_error(500, "Internal error; it has been logged.", "error")


def is_api_path(path: str) -> bool:
    return path.startswith(API_PREFIX)


def unavailable(exc: BaseException) -> str | None:
    """Which backing service ``exc`` says is down ("redis", "database"), or None."""
    if isinstance(exc, RedisConnectionError | RedisTimeout):
        return "redis"
    if isinstance(exc, OperationalError | InterfaceError):
        return "database"
    return None


UNAVAILABLE_TEXT = {
    "redis": "Redis (live state and messaging) is not reachable",
    "database": "the database is not reachable",
}


def unavailable_detail(service: str) -> str:
    return f"service unavailable: {UNAVAILABLE_TEXT[service]}; try again in a moment."


def bad_request_detail(exc: BaseException | None) -> tuple[str, str]:
    """(detail, code) for a request Django refused before any view ran."""
    if isinstance(exc, RequestDataTooBig):
        limit = settings.DATA_UPLOAD_MAX_MEMORY_SIZE
        return f"Request body too large (at most {limit} bytes).", "too_large"
    if isinstance(exc, TooManyFieldsSent):
        return "Too many form fields.", "too_large"
    return "Bad request.", "bad_request"


def api_exception_handler(exc: Exception, context: dict[str, Any]) -> Response | None:
    if isinstance(exc, RobotError):
        return Response(error_body(exc.message, exc.code, getattr(exc, "field", None)), status=exc.status_code)
    service = unavailable(exc)
    if service:
        return Response(error_body(unavailable_detail(service), "unavailable"),
                        status=status.HTTP_503_SERVICE_UNAVAILABLE)
    if isinstance(exc, SuspiciousOperation):
        detail, code = bad_request_detail(exc)
        return Response(error_body(detail, code), status=status.HTTP_400_BAD_REQUEST)
    if isinstance(exc, exceptions.ValidationError):
        return Response(_validation_body(exc.detail), status=status.HTTP_400_BAD_REQUEST)
    response = exception_handler(exc, context)
    if response is not None:
        data = response.data
        found = data.get("detail") if isinstance(data, dict) else data
        response.data = error_body(str(found), getattr(exc, "default_code", "error"))
    return response


def _first(messages: Any) -> tuple[list[str], str]:
    """The path to the first message in a (possibly nested) DRF error detail, and the message."""
    path: list[str] = []
    while isinstance(messages, dict | list) and messages:
        if isinstance(messages, dict):
            key = next(iter(messages))
            path.append(str(key))
            messages = messages[key]
        else:
            messages = next((m for m in messages if m), messages[0])
    return path, str(messages)


def _validation_body(detail: Any) -> dict[str, Any]:
    path, message = _first(detail)
    path = [p for p in path if p != "non_field_errors"]
    if not path:
        return {**error_body(message, "invalid"), "errors": detail}
    field = ".".join(path)
    return {**error_body(f"{field}: {message}", "invalid", field), "errors": detail}


def body_problem(data: Any) -> tuple[str, str] | None:
    """(field path, reason) for the first thing in a parsed JSON body the API never accepts:
    nesting deeper than ``MAX_JSON_DEPTH``, or text (keys too) against the text policy."""
    stack: list[tuple[Any, str, int]] = [(data, "", 1)]
    while stack:
        item, path, level = stack.pop()
        if isinstance(item, str):
            reason = character_problem(item)
            if reason:
                return path or "body", reason
        elif isinstance(item, dict | list):
            if level > MAX_JSON_DEPTH:
                return path or "body", f"nested too deeply (at most {MAX_JSON_DEPTH} levels)."
            pairs = item.items() if isinstance(item, dict) else enumerate(item)
            for key, child in pairs:
                name = f"{path}.{key}" if path else str(key)
                if isinstance(key, str) and (reason := character_problem(key)):
                    return scrub(name), f"field name {reason}"
                stack.append((child, scrub(name), level + 1))
    return None


def refuse_bad_body(data: Any) -> None:
    problem = body_problem(data)
    if problem:
        field, reason = problem
        raise exceptions.ValidationError({field: [reason]})


class BoundedJSONParser(JSONParser):
    """DRF's JSON parser, refusing (400) deep nesting instead of recursing to death, and text
    the site's text policy never accepts, naming where it is."""

    def parse(self, stream: Any, media_type: str | None = None, parser_context: Any = None) -> Any:
        try:
            data = super().parse(stream, media_type, parser_context)
        except RecursionError:
            raise exceptions.ParseError(f"JSON nested too deeply (at most {MAX_JSON_DEPTH} levels).") from None
        refuse_bad_body(data)
        return data


class _FormPolicy:
    """Form bodies (plain or multipart) under the same text policy as JSON ones."""

    def parse(self, stream: Any, media_type: str | None = None, parser_context: Any = None) -> Any:
        parsed = super().parse(stream, media_type, parser_context)  # type: ignore[misc]
        for name, values in getattr(parsed, "data", parsed).lists():
            for value in values:
                refuse_bad_body({name: value})
        return parsed


class PolicyFormParser(_FormPolicy, FormParser):
    pass


class PolicyMultiPartParser(_FormPolicy, MultiPartParser):
    pass


class SafeJSONRenderer(JSONRenderer):
    """Renders anything, including text with lone surrogates from the robot or old rows (as U+FFFD)."""

    def render(self, data: Any, accepted_media_type: str | None = None, renderer_context: Any = None) -> Any:
        try:
            return super().render(data, accepted_media_type, renderer_context)
        except UnicodeEncodeError:
            return super().render(scrub_json(data), accepted_media_type, renderer_context)

