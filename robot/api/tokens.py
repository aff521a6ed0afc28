"""API tokens: they expire, die with a password change, and are trusted from a very short
per-process cache, so scripts polling the API cost almost no query."""

from __future__ import annotations

import time
from datetime import datetime, timedelta
from typing import Any

from django.conf import settings
from django.contrib.auth import get_user_model
from django.db import transaction
from django.db.models.signals import post_delete, post_save
from django.dispatch import receiver
from django.utils import timezone
from rest_framework.authentication import TokenAuthentication
from rest_framework.authtoken.models import Token
from rest_framework.exceptions import AuthenticationFailed, ValidationError

from robot.models import TokenExpiry

# A valid token is trusted this long without asking the database again (per process): a deleted
# token, an expired one or a deactivated or demoted user stops working within this time in every
# web process (at once in the process that made the change), at one query per token per period.
TOKEN_CACHE_S = 0.5
_TOKEN_CACHE_MAX = 10_000


def expires_at(token: Token) -> datetime | None:
    chosen = TokenExpiry.objects.filter(token=token).values_list("expires", flat=True).first()
    if chosen is not None:
        return chosen
    days = settings.API_TOKEN_DAYS
    return token.created + timedelta(days=days) if days > 0 else None


def is_expired(token: Token) -> bool:
    end = expires_at(token)
    return end is not None and end <= timezone.now()


def token_for(user: Any) -> Token:
    """The user's token, a new one when theirs has expired."""
    token, created = Token.objects.get_or_create(user=user)
    if not created and is_expired(token):
        token.delete()
        token = Token.objects.create(user=user)
    return token


def token_create(*, user: Any, days: float) -> Token:
    """A new token for ``user`` that ends ``days`` from now (at most ``API_TOKEN_DAYS``, when that is
    set); it takes the place of the one they had."""
    longest = settings.API_TOKEN_DAYS
    if not days > 0 or (longest > 0 and days > longest):
        raise ValidationError({"days": [f"more than 0 and at most {longest:g}" if longest > 0 else "more than 0"]})
    with transaction.atomic():
        Token.objects.filter(user=user).delete()
        token = Token.objects.create(user=user)
        TokenExpiry.objects.create(token=token, expires=timezone.now() + timedelta(days=days))
    return token


def token_revoke(*, user: Any) -> bool:
    """End ``user``'s token; False when they had none."""
    deleted, _ = Token.objects.filter(user=user).delete()
    return deleted > 0


class CachedTokenAuthentication(TokenAuthentication):
    _cache: dict[str, tuple[float, Any, Any]] = {}

    def authenticate_credentials(self, key: str) -> tuple[Any, Any]:
        now = time.monotonic()
        hit = self._cache.get(key)
        if hit is not None and hit[0] > now:
            return hit[1], hit[2]
        user, token = super().authenticate_credentials(key)  # AuthenticationFailed when unknown or inactive
        if is_expired(token):
            token.delete()
            raise AuthenticationFailed("Token expired: get a new one (POST /api/auth/token/).")
        if len(self._cache) >= _TOKEN_CACHE_MAX:
            self._cache.clear()
        self._cache[key] = (now + TOKEN_CACHE_S, user, token)
        return user, token


@receiver(post_delete, sender=Token)
def _forget_deleted_token(sender: type, instance: Token, **kwargs: Any) -> None:
    CachedTokenAuthentication._cache.pop(instance.key, None)


@receiver(post_save, sender=get_user_model())
def _password_changed(sender: type, instance: Any, created: bool, **kwargs: Any) -> None:
    # set_password() leaves the new password here until save() has run (and its signals).
    if not created and getattr(instance, "_password", None) is not None:
        for token in Token.objects.filter(user=instance):
            token.delete()
