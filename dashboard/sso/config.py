"""The single sign-on settings, read once from Django's settings (the environment)."""

from __future__ import annotations

from dataclasses import dataclass

from django.conf import settings

from cyborg_site.roles import Role


class SsoConfigError(ValueError):
    pass


@dataclass(frozen=True)
class RoleRule:
    """A claim value (a group, a role) or, written ``@domain``, a verified e-mail domain, and the role it gives."""

    match: str
    role: Role

    @property
    def by_email_domain(self) -> bool:
        return self.match.startswith("@")


@dataclass(frozen=True)
class SsoConfig:
    issuer: str
    client_id: str
    client_secret: str
    scopes: str
    name: str
    role_claim: str
    rules: tuple[RoleRule, ...]
    default_role: Role | None
    leeway_s: int

    @property
    def metadata_url(self) -> str:
        return self.issuer.rstrip("/") + "/.well-known/openid-configuration"


def parse_rules(text: str) -> tuple[RoleRule, ...]:
    """``"cyborg-admins=admin cyborg-operators=operator @ntnu.no=viewer"`` (spaces or commas between)."""
    rules = []
    for item in text.replace(",", " ").split():
        match, sep, role = item.rpartition("=")
        if not sep or not match or role not in Role:
            raise SsoConfigError(f"OIDC_ROLES: {item!r} is not VALUE=ROLE with ROLE one of viewer, operator, admin")
        rules.append(RoleRule(match, Role(role)))
    return tuple(rules)


def sso_config() -> SsoConfig | None:
    """The provider's settings, or None when single sign-on is not configured."""
    if not settings.OIDC_ISSUER:
        return None
    return SsoConfig(
        issuer=settings.OIDC_ISSUER, client_id=settings.OIDC_CLIENT_ID, client_secret=settings.OIDC_CLIENT_SECRET,
        scopes=settings.OIDC_SCOPES, name=settings.OIDC_NAME, role_claim=settings.OIDC_ROLE_CLAIM,
        rules=parse_rules(settings.OIDC_ROLES),
        default_role=Role(settings.OIDC_DEFAULT_ROLE) if settings.OIDC_DEFAULT_ROLE else None,
        leeway_s=settings.OIDC_LEEWAY_S,
    )


def config_problems() -> list[str]:
    """What is wrong with the single sign-on settings (a system check shows each)."""
    try:
        config = sso_config()
    except (SsoConfigError, ValueError) as exc:
        return [str(exc)]
    if config is None:
        required = "SSO_REQUIRED is set but OIDC_ISSUER is not: nobody but superusers could log in"
        return [required] if settings.SSO_REQUIRED else []
    problems = [f"{name} is not set" for name in ("OIDC_CLIENT_ID", "OIDC_CLIENT_SECRET")
                if not getattr(settings, name)]
    if "openid" not in config.scopes.split():
        problems.append("OIDC_SCOPES must include openid")
    if not config.rules and config.default_role is None:
        problems.append("neither OIDC_ROLES nor OIDC_DEFAULT_ROLE is set: every sign-in would be refused")
    return problems
