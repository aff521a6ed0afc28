"""Who may press the E-STOP when the database, which knows every session and token, is down.

- A page: every response to an operator's request carries a signed *E-STOP pass* cookie (their
  id, name and password hash's fingerprint; signed with the server's key, so every web process
  can read it without a query). Logging out, or losing the role, removes it on the next response.
- A script: a token this process has trusted before counts, however long ago.

Both are tried first, and only by the E-STOP views (``EstopAccessMixin``), with the usual CSRF check
for the cookie: a frozen database would hold up the session's or the token's query, and a stop can
do no harm (a pass outlives a revocation until its holder's next response, a trusted token until
this process forgets it). What such a press does is audited like any other.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from django.conf import settings
from django.core import signing
from django.http import HttpRequest, HttpResponseBase
from rest_framework.authentication import SessionAuthentication
from rest_framework.request import Request

from cyborg_site.roles import Role, is_operator, roles_cached
from robot.api.tokens import CachedTokenAuthentication

COOKIE = "cyborg_estop_pass"
_SALT = "cyborg.estop-pass"


@dataclass
class PassUser:
    """An operator known from their E-STOP pass or a trusted token, while the database is down."""

    pk: int
    username: str
    is_authenticated: bool = True
    is_anonymous: bool = False
    is_active: bool = True
    is_superuser: bool = False
    _role_groups: set[str] = field(default_factory=lambda: {Role.OPERATOR.value})

    @property
    def id(self) -> int:
        return self.pk

    def get_username(self) -> str:
        return self.username


def _read_pass(raw: str | None) -> dict[str, Any] | None:
    try:
        return signing.loads(raw or "", salt=_SALT, max_age=settings.SESSION_COOKIE_AGE)
    except signing.BadSignature:
        return None


def pass_user(request: HttpRequest) -> PassUser | None:
    data = _read_pass(request.COOKIES.get(COOKIE))
    return PassUser(pk=int(data["u"]), username=str(data["n"])) if data else None


class EstopPassMiddleware:
    """Keeps the pass cookie in step with the session: set for an operator (once the request has
    loaded the user and their roles anyway), removed for anyone else."""

    def __init__(self, get_response: Callable[[HttpRequest], HttpResponseBase]) -> None:
        self.get_response = get_response

    def __call__(self, request: HttpRequest) -> HttpResponseBase:
        response = self.get_response(request)
        user = getattr(request, "_cached_user", None)  # loaded by this request: no query of ours
        if user is None or isinstance(user, PassUser):
            return response
        current = request.COOKIES.get(COOKIE)
        if user.is_authenticated and roles_cached(user) and is_operator(user):
            wanted = {"u": user.pk, "n": user.get_username(), "h": user.get_session_auth_hash()[:16]}
            if _read_pass(current) != wanted:  # none yet, expired, someone else's, or an old name or password
                response.set_cookie(
                    COOKIE, signing.dumps(wanted, salt=_SALT), max_age=settings.SESSION_COOKIE_AGE,
                    secure=settings.SESSION_COOKIE_SECURE, httponly=True, samesite="Lax")
        elif current and (not user.is_authenticated or roles_cached(user)):
            response.delete_cookie(COOKIE, samesite="Lax")
        return response


class EstopAccessMixin:
    """For the E-STOP views: a token this process trusted before or the operator's pass cookie (with
    the CSRF check a session gets), first, so a database that is down or frozen never holds up a
    stop; else their usual authentication (token, then session)."""

    def perform_authentication(self, request: Request) -> None:
        if not _known_without_database(request):
            super().perform_authentication(request)  # type: ignore[misc]


def _known_without_database(request: Request) -> bool:
    scheme, _, key = request.META.get("HTTP_AUTHORIZATION", "").partition(" ")
    if scheme.lower() == CachedTokenAuthentication.keyword.lower():
        hit = CachedTokenAuthentication._cache.get(key.strip())  # however long ago
        if hit is None or not (roles_cached(hit[1]) and is_operator(hit[1])):
            return False
        _authenticated(request, CachedTokenAuthentication(), hit[1], hit[2])
        return True
    user = pass_user(request._request)
    if user is None:
        return False
    session = SessionAuthentication()
    session.enforce_csrf(request)
    _authenticated(request, session, user, None)
    return True


def _authenticated(request: Request, authenticator: Any, user: Any, auth: Any) -> None:
    """What DRF's own authentication leaves on the request (``successful_authenticator`` says which)."""
    request._authenticator = authenticator  # type: ignore[attr-defined]
    request.user, request.auth = user, auth
