"""Role groups and user creation, shared by migrations hooks, commands and tests."""

from __future__ import annotations

import secrets
from typing import Any

from django.contrib.auth.models import Group, Permission, User
from django.contrib.auth.password_validation import validate_password
from django.core.exceptions import ValidationError

from cyborg_site.roles import Role

# Admins manage users and the robot's configuration in the Django admin.
_ADMIN_APPS = ("auth", "robot", "history", "authtoken", "axes")


def ensure_role_groups() -> dict[Role, Group]:
    groups = {role: Group.objects.get_or_create(name=role.value)[0] for role in Role}
    groups[Role.ADMIN].permissions.set(Permission.objects.filter(content_type__app_label__in=_ADMIN_APPS))
    return groups


def role_holders(instance: Any, action: str, reverse: bool, pk_set: set[Any] | None) -> list[User]:
    """The people whose roles an ``m2m_changed`` of ``User.groups`` changes: the user, or, changed from
    a group's side, the users added or removed, or the members a clear takes (known only before it, so
    kept on the group at ``pre_clear``)."""
    if not reverse:
        return [instance]
    if action == "pre_clear":
        instance._role_holders = list(instance.user_set.all())
    if action.endswith("_clear"):
        return list(getattr(instance, "_role_holders", ()))
    return list(User.objects.filter(pk__in=pk_set or ()))


def password_problems(password: str, *, username: str, email: str = "") -> list[str]:
    """Why the password validators (``AUTH_PASSWORD_VALIDATORS``) refuse ``password`` for this user
    (empty when they accept it)."""
    user = User.objects.filter(username=username).first() or User(username=username, email=email)
    try:
        validate_password(password, user)
    except ValidationError as exc:
        return list(exc.messages)
    return []


def create_user(username: str, role: Role, *, password: str | None = None, email: str = "") -> tuple[User, str]:
    """Create (or reset) ``username`` with ``role``; returns the user and the password."""
    password = password or secrets.token_urlsafe(12)
    groups = ensure_role_groups()
    user, _ = User.objects.get_or_create(username=username, defaults={"email": email})
    user.set_password(password)
    user.is_staff = role == Role.ADMIN
    user.is_superuser = role == Role.ADMIN
    user.save()
    user.groups.set([groups[role]])
    return user, password
