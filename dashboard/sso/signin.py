"""One sign-in through the provider, once its answer is verified: the role from the claims, the
lockout, the account, the session, the audit entry; or the reason it is refused."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from axes.handlers.proxy import AxesProxyHandler
from django.contrib.auth import login, user_login_failed
from django.http import HttpRequest

from dashboard.sso.config import SsoConfig
from dashboard.sso.people import AccountDisabled, account_for
from dashboard.sso.roles import role_for
from robot.commands.audit import audit_record

ID_TOKEN_KEY = "sso_id_token"


@dataclass(frozen=True)
class Refusal:
    code: str
    message: str


def _audit(user: Any, claims: Mapping[str, Any], *, refusal: Refusal | None = None, role: str = "") -> None:
    params = {"sub": str(claims.get("sub", "")), "username": str(claims.get("preferred_username", "")),
              "issuer": str(claims.get("iss", ""))}
    audit_record(user=user, source="page", action="login.sso", params=params, ok=refusal is None,
                 outcome=refusal.message if refusal else f"signed in as {role}",
                 error_code=refusal.code if refusal else "")


def refuse(request: HttpRequest, claims: Mapping[str, Any], refusal: Refusal) -> Refusal:
    """Audit the refusal and count it as a failed login (django-axes: forged answers lead to a lockout)."""
    _audit(None, claims, refusal=refusal)
    user_login_failed.send(sender=__name__, request=request,
                           credentials={"username": str(claims.get("preferred_username", ""))})
    return refusal


def sign_in(request: HttpRequest, config: SsoConfig, claims: Mapping[str, Any], id_token: str) -> Refusal | None:
    """Log the person in (None), or say why not."""
    username = str(claims.get("preferred_username", ""))
    if AxesProxyHandler.is_locked(request, credentials={"username": username}):
        return refuse(request, claims, Refusal("locked_out", "Too many failed logins from here: try again later."))
    role = role_for(claims, config)
    if role is None:
        return refuse(request, claims, Refusal(
            "no_role", f"Your account at {config.name} is not in a group that may use the Cyborg. "
                       "Ask the team to add you, then sign in again."))
    try:
        user = account_for(config.issuer, claims, role)
    except AccountDisabled:
        return refuse(request, claims, Refusal("disabled", "Your account here has been deactivated by an admin."))
    login(request, user, backend="django.contrib.auth.backends.ModelBackend")
    request.session[ID_TOKEN_KEY] = id_token
    _audit(user, claims, role=role.value)
    return None
