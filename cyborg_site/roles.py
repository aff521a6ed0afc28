"""The three roles: viewers watch, operators command and drive, admins also configure."""

from __future__ import annotations

from enum import StrEnum
from typing import Any

from django.conf import settings
from django.utils.functional import empty


class Role(StrEnum):
    VIEWER = "viewer"
    OPERATOR = "operator"
    ADMIN = "admin"


def _groups(user: Any) -> set[str]:
    cached = getattr(user, "_role_groups", None)
    if cached is None:
        cached = set(user.groups.values_list("name", flat=True)) if user.is_authenticated else set()
        user._role_groups = cached
    return cached


def load_roles(user: Any) -> Any:
    """``user`` with its groups read, so the role checks below ask the database nothing more."""
    _groups(user)
    return user


def roles_cached(user: Any) -> bool:
    """Whether the role checks below can answer for ``user`` without a query (safe on an event loop)."""
    # A lazy user (request.user, a socket's scope user) counts only once resolved: touching
    # an unresolved one would run its loading query.
    target = getattr(user, "_wrapped", user)
    return target is not empty and getattr(target, "_role_groups", None) is not None


def is_admin(user: Any) -> bool:
    return bool(user and user.is_authenticated and (user.is_superuser or Role.ADMIN in _groups(user)))


def is_operator(user: Any) -> bool:
    return is_admin(user) or bool(user and user.is_authenticated and Role.OPERATOR in _groups(user))


def role_of(user: Any) -> Role | None:
    if is_admin(user):
        return Role.ADMIN
    if is_operator(user):
        return Role.OPERATOR
    if user and user.is_authenticated:
        return Role.VIEWER
    return None


def may_sign_in_with_password(user: Any) -> bool:
    """With single sign-on required, a local password is for break-glass accounts only."""
    return (not settings.SSO_REQUIRED or not settings.OIDC_ISSUER or user.is_superuser
            or user.has_perm("dashboard.sign_in_with_password"))
