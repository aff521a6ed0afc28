"""The site's error handlers: the API's one JSON shape under /api/, a clear page elsewhere.

The page is rendered without the request's context processors, so it still renders while
the database or Redis (which those would query) is down.
"""

from __future__ import annotations

import logging
import sys

from django.http import HttpRequest, HttpResponse
from django.template.loader import render_to_string

from robot.api.errors import (
    UNAVAILABLE_TEXT,
    api_error,
    api_server_error,
    bad_request_detail,
    is_api_path,
    unavailable,
)

log = logging.getLogger(__name__)


def error_page(status: int, title: str, message: str, *, retry: bool = False) -> HttpResponse:
    html = render_to_string("errors/error.html", {"title": title, "message": message, "retry": retry})
    response = HttpResponse(html, status=status)
    if retry:
        response["Retry-After"] = "5"
    return response


def bad_request(request: HttpRequest, exception: Exception | None = None) -> HttpResponse:
    detail, code = bad_request_detail(exception)
    if is_api_path(request.path):
        return api_error(400, detail, code)
    return error_page(400, "Bad request", detail)


def permission_denied(request: HttpRequest, exception: Exception | None = None) -> HttpResponse:
    detail = "You do not have permission to do this."
    if is_api_path(request.path):
        return api_error(403, detail, "permission_denied")
    return error_page(403, "Not allowed", detail)


def not_found(request: HttpRequest, exception: Exception | None = None) -> HttpResponse:
    if is_api_path(request.path):
        return api_error(404, f"No API endpoint at {request.path}; see /api/docs/.", "not_found")
    return error_page(404, "Page not found", f"There is no page at {request.path}.")


def server_error(request: HttpRequest) -> HttpResponse:
    # Django calls this from inside its except block: the exception is still at hand.
    exc = sys.exc_info()[1]
    if is_api_path(request.path):
        return api_server_error(exc)
    service = unavailable(exc) if exc else None
    if service:
        return error_page(503, "Temporarily unavailable",
                          f"The ground station cannot work right now: {UNAVAILABLE_TEXT[service]}.", retry=True)
    return error_page(500, "Something went wrong", "An internal error occurred; it has been logged.")
