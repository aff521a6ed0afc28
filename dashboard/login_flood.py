"""A flood of failed logins against one account from many addresses, slowed without keeping its
owner out (the "device cookie" of OWASP's guidance on credential guessing).

django-axes locks an (account, address) pair and an address, never an account everywhere: anyone
could then keep the operators from logging in to press the E-STOP. But from many addresses a
guesser gets ``LOGIN_FAILURE_LIMIT`` tries from each. So once an account has had
``LOGIN_FLOOD_LIMIT`` failures within ``LOGIN_LOCKOUT_MINUTES`` (from anywhere), it accepts a
password only from a browser that has logged in to it before (a signed cookie set at each
successful login), until the failures age out or an admin clears them; everyone else gets the
lockout answer, which says so. A guesser's browser never has the cookie, so the flood stops
counting; its owner logs in as usual from their own browser.
"""

from __future__ import annotations

from collections.abc import Callable
from datetime import timedelta
from typing import Any

from axes.models import AccessAttempt
from django.conf import settings
from django.contrib.auth.signals import user_logged_in
from django.core import signing
from django.core.exceptions import PermissionDenied
from django.db.models import Sum
from django.dispatch import receiver
from django.http import HttpRequest, HttpResponseBase
from django.utils import timezone

COOKIE = "cyborg_device"
_SALT = "cyborg.device"
DEVICE_DAYS = 180
_MAX_ACCOUNTS = 8  # accounts one browser is known for (a shared lab computer)


def failures_everywhere(username: str) -> int:
    """The account's failed logins from every address within the lockout window."""
    since = timezone.now() - settings.AXES_COOLOFF_TIME
    total = AccessAttempt.objects.filter(username=username, attempt_time__gte=since) \
        .aggregate(total=Sum("failures_since_start"))["total"]
    return int(total or 0)


def known_accounts(request: HttpRequest) -> list[str]:
    raw = request.COOKIES.get(COOKIE)
    if not raw:
        return []
    try:
        names = signing.loads(raw, salt=_SALT, max_age=timedelta(days=DEVICE_DAYS))
    except signing.BadSignature:
        return []
    return [str(name) for name in names] if isinstance(names, list) else []


def refused_as_flooded(request: Any, username: str) -> bool:
    """Whether this login must be refused: the account is flooded and this browser is not its owner's."""
    return failures_everywhere(username) >= settings.LOGIN_FLOOD_LIMIT and \
        username not in known_accounts(getattr(request, "_request", request))


class FloodGuardBackend:
    """Before the password is checked: refuses (as a lockout). No ``get_user``: it never logs anyone
    in, and a test client's ``force_login`` takes the first backend that has one."""

    def authenticate(self, request: Any, username: str | None = None, password: str | None = None,
                     **kwargs: Any) -> None:
        if request is not None and username and refused_as_flooded(request, username):
            request.login_flooded = True
            request.axes_locked_out = True  # answered by the lockout callable (dashboard.lockouts)
            raise PermissionDenied
        return None


@receiver(user_logged_in)
def _remember_browser(sender: type, request: Any, user: Any, **kwargs: Any) -> None:
    if request is not None:
        request._device_account = user.get_username()


class DeviceCookieMiddleware:
    """Sets the cookie on the response to a successful login."""

    def __init__(self, get_response: Callable[[HttpRequest], HttpResponseBase]) -> None:
        self.get_response = get_response

    def __call__(self, request: HttpRequest) -> HttpResponseBase:
        response = self.get_response(request)
        name = getattr(request, "_device_account", None)
        if name:
            names = [name, *(n for n in known_accounts(request) if n != name)][:_MAX_ACCOUNTS]
            response.set_cookie(COOKIE, signing.dumps(names, salt=_SALT), max_age=DEVICE_DAYS * 86400,
                                secure=settings.SESSION_COOKIE_SECURE, httponly=True, samesite="Lax")
        return response
