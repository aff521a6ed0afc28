"""Login throttling (django-axes) as this site shows it: the lockout answer on the login page
and the token endpoint, the audit entry, and the client address behind a proxy."""

from __future__ import annotations

from typing import Any

from django.conf import settings
from django.http import HttpRequest, HttpResponse
from django.shortcuts import render

from robot.api.auth import lockout_message
from robot.api.errors import api_error, is_api_path
from robot.commands.audit import audit_record


def lockout_response(request: HttpRequest, original_response: Any = None, credentials: Any = None) -> HttpResponse:
    """429 in the API's error shape, or the login page with a notice."""
    response: HttpResponse
    message = lockout_message(flooded=getattr(request, "login_flooded", False))
    if is_api_path(request.path):
        response = api_error(429, message, "locked_out")
    else:
        response = render(request, "registration/login.html", {"lockout": message}, status=429)
    response["Retry-After"] = str(int(settings.AXES_COOLOFF_TIME.total_seconds()))
    return response


def client_ip(request: HttpRequest) -> str:
    """The address a lockout counts against (behind a trusted proxy, the client's: cyborg_site.client_address)."""
    return request.META.get("REMOTE_ADDR", "")


def audit_lockout(sender: Any, request: HttpRequest, username: str | None, ip_address: str | None,
                  **kwargs: Any) -> None:
    audit_record(user=None, source="api" if request is not None and is_api_path(request.path) else "page",
                 action="login.lockout", params={"username": username or "", "ip_address": ip_address or ""},
                 ok=False, outcome=f"locked out after {settings.AXES_FAILURE_LIMIT} failed logins",
                 error_code="locked_out")
