"""The local account an SSO identity signs in to: made at its first login, its role set at every login."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from django.contrib.auth import get_user_model
from django.db import transaction

from cyborg_site.roles import Role
from dashboard.accounts import ensure_role_groups
from dashboard.models import SsoIdentity

User = get_user_model()


class AccountDisabled(Exception):
    pass


def _free_username(wanted: str) -> str:
    base = "".join(ch for ch in wanted if ch.isalnum() or ch in "@.+-_")[:140] or "user"
    name, n = base, 1
    while User.objects.filter(username=name).exists():
        n += 1
        name = f"{base}-{n}"
    return name


@transaction.atomic
def account_for(issuer: str, claims: Mapping[str, Any], role: Role) -> Any:
    """The account of the identity ``(issuer, sub)``, made if new; its e-mail, name and role as the
    provider now says (a person taken out of a group loses that role here). ``AccountDisabled`` if an
    admin deactivated it."""
    subject = str(claims["sub"])
    identity = SsoIdentity.objects.select_related("user").filter(issuer=issuer, subject=subject).first()
    if identity is None:
        wanted = claims.get("preferred_username") or claims.get("email") or subject
        user = User(username=_free_username(str(wanted)))
        user.set_unusable_password()
        user.save()
        identity = SsoIdentity.objects.create(user=user, issuer=issuer, subject=subject)
    user = identity.user
    if not user.is_active:
        raise AccountDisabled(user.get_username())
    user.email = str(claims.get("email") or user.email)
    user.first_name = str(claims.get("given_name") or user.first_name)[:150]
    user.last_name = str(claims.get("family_name") or user.last_name)[:150]
    user.is_staff = role == Role.ADMIN
    user.save()
    user.groups.set([ensure_role_groups()[role]])
    identity.role = role.value
    identity.save(update_fields=["role", "last_login"])
    return user

