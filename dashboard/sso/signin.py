"""One sign-in through the provider, once its answer is verified: the role from the claims, the
lockout, the account, the session, the audit entry; or the reason it is refused.

Only a forged or broken answer counts as a failed login from the address (django-axes). A valid
sign-in the mapping refuses does not: hundreds may share a campus address, and people outside the
groups must not lock the operators out. It is throttled per identity (issuer and subject) instead."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, cast

from axes.handlers.proxy import AxesProxyHandler
from django.conf import settings
from django.contrib import messages
from django.contrib.auth import login, user_login_failed
from django.http import HttpRequest
from rest_framework.throttling import SimpleRateThrottle

from dashboard.sso.config import SsoConfig
from dashboard.sso.people import AccountDisabled, account_for
from dashboard.sso.roles import absent_claims, matched_role
from robot.api.auth import lockout_message
from robot.commands.audit import audit_record

ID_TOKEN_KEY = "sso_id_token"


@dataclass(frozen=True)
class Refusal:
    code: str
    message: str
    status: int = 403


class RefusedIdentityThrottle(SimpleRateThrottle):
    """``LOGIN_FAILURE_LIMIT`` refused sign-ins of one identity within ``LOGIN_LOCKOUT_MINUTES``."""

    scope = "sso_refused"

    def __init__(self, issuer: str, subject: str) -> None:
        self.identity = f"{issuer}#{subject}"
        super().__init__()

    def get_rate(self) -> str:
        return "identity"  # parse_rate reads the settings

    def parse_rate(self, rate: str | None) -> tuple[int, int]:
        return settings.AXES_FAILURE_LIMIT, max(1, int(settings.AXES_COOLOFF_TIME.total_seconds()))

    def get_cache_key(self, request: Any, view: Any) -> str:
        return self.cache_format % {"scope": self.scope, "ident": self.identity}


def _audit(user: Any, claims: Mapping[str, Any], *, refusal: Refusal | None = None, outcome: str = "") -> None:
    params = {"sub": str(claims.get("sub", "")), "username": str(claims.get("preferred_username", "")),
              "issuer": str(claims.get("iss", ""))}
    audit_record(user=user, source="page", action="login.sso", params=params, ok=refusal is None,
                 outcome=refusal.message if refusal else outcome, error_code=refusal.code if refusal else "")


def refuse(request: HttpRequest, claims: Mapping[str, Any], refusal: Refusal, *, counts: bool) -> Refusal:
    """Audit the refusal; ``counts``: a forged or broken answer, counted as a failed login from the
    address (django-axes: they lead to a lockout)."""
    _audit(None, claims, refusal=refusal)
    if counts:
        user_login_failed.send(sender=__name__, request=request,
                               credentials={"username": str(claims.get("preferred_username", ""))})
    return refusal


def _not_sent(config: SsoConfig, names: list[str]) -> str:
    listed = " and ".join(f"'{name}'" for name in names)
    return f"{config.name} sent no {listed} claim (neither in the ID token nor at its userinfo endpoint)"


def _refused_by_mapping(request: HttpRequest, config: SsoConfig, claims: Mapping[str, Any],
                        refusal: Refusal) -> Refusal:
    throttle = RefusedIdentityThrottle(config.issuer, str(claims.get("sub", "")))
    if not throttle.allow_request(cast(Any, request), cast(Any, None)):  # neither read: the key is the identity
        minutes = settings.AXES_COOLOFF_TIME.total_seconds() / 60
        refusal = Refusal("throttled", f"Your account at {config.name} was refused here too often: {refusal.message} "
                                       f"Try again in {minutes:g} minutes.", status=429)
    return refuse(request, claims, refusal, counts=False)


def sign_in(request: HttpRequest, config: SsoConfig, claims: Mapping[str, Any], id_token: str) -> Refusal | None:
    """Log the person in (None), or say why not."""
    username = str(claims.get("preferred_username", ""))
    if AxesProxyHandler.is_locked(request, credentials={"username": username}):
        return refuse(request, claims, Refusal("locked_out", lockout_message(), status=429), counts=False)
    absent = absent_claims(claims, config)
    matched = matched_role(claims, config)
    role = matched or config.default_role
    if role is None:
        why = (f"{_not_sent(config, absent)}, so it does not say which group" if absent
               else f"Your account at {config.name} is not in a group that may use the Cyborg")
        return _refused_by_mapping(request, config, claims, Refusal(
            "no_role", f"{why}. Ask the team to add you, then sign in again."))
    try:
        user = account_for(config.issuer, claims, role)
    except AccountDisabled:
        return _refused_by_mapping(request, config, claims, Refusal(
            "disabled", "Your account here has been deactivated by an admin."))
    login(request, user, backend="django.contrib.auth.backends.ModelBackend")
    request.session[ID_TOKEN_KEY] = id_token
    outcome = f"signed in as {role.value}"
    if matched is None and absent:
        outcome += f", the default role: {_not_sent(config, absent)}"
        messages.warning(request, f"You are signed in as {role.value}, the default role: {_not_sent(config, absent)}. "
                                  "Ask an admin to have the provider send it.")
    _audit(user, claims, outcome=outcome)
    return None
