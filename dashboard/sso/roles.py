"""Which role a person's claims give them: the highest any rule matches, else the default (if any)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

from cyborg_site.roles import Role
from dashboard.sso.config import SsoConfig

_RANK = {Role.VIEWER: 0, Role.OPERATOR: 1, Role.ADMIN: 2}


def claim_values(claims: Mapping[str, Any], name: str) -> set[str]:
    value = claims.get(name)
    if isinstance(value, str):
        return {value}
    if isinstance(value, Iterable) and not isinstance(value, Mapping):
        return {item for item in value if isinstance(item, str)}
    return set()


def verified_email_domain(claims: Mapping[str, Any]) -> str:
    email = claims.get("email")
    if not isinstance(email, str) or "@" not in email or claims.get("email_verified") is not True:
        return ""
    return "@" + email.rpartition("@")[2].lower()


def matched_role(claims: Mapping[str, Any], config: SsoConfig) -> Role | None:
    """The highest role a rule gives, without the default."""
    values = claim_values(claims, config.role_claim)
    domain = verified_email_domain(claims)
    matched = [rule.role for rule in config.rules
               if (rule.match.lower() == domain if rule.by_email_domain else rule.match in values)]
    return max(matched, key=_RANK.__getitem__) if matched else None


def role_for(claims: Mapping[str, Any], config: SsoConfig) -> Role | None:
    return matched_role(claims, config) or config.default_role


def absent_claims(claims: Mapping[str, Any], config: SsoConfig) -> list[str]:
    """The claims a rule reads that the provider did not send at all (the role claim; the e-mail
    when a rule matches by its domain)."""
    read = [config.role_claim, *(["email"] if any(rule.by_email_domain for rule in config.rules) else [])]
    return [name for name in read if name not in claims]
