"""Token authentication with a short per-process cache, so scripts polling the API cost no query."""

from __future__ import annotations

import time
from typing import Any

from django.db.models.signals import post_delete
from django.dispatch import receiver
from rest_framework.authentication import TokenAuthentication
from rest_framework.authtoken.models import Token

# A valid token is trusted this long without asking the database again (per process), so a
# script polling the API costs no query per request; a deleted token or deactivated user stops
# working within this time everywhere (at once in the process that deleted the token).
TOKEN_CACHE_S = 10.0
_TOKEN_CACHE_MAX = 10_000


class CachedTokenAuthentication(TokenAuthentication):
    _cache: dict[str, tuple[float, Any, Any]] = {}

    def authenticate_credentials(self, key: str) -> tuple[Any, Any]:
        now = time.monotonic()
        hit = self._cache.get(key)
        if hit is not None and hit[0] > now:
            return hit[1], hit[2]
        user, token = super().authenticate_credentials(key)  # AuthenticationFailed when unknown or inactive
        if len(self._cache) >= _TOKEN_CACHE_MAX:
            self._cache.clear()
        self._cache[key] = (now + TOKEN_CACHE_S, user, token)
        return user, token

    @classmethod
    def cached_user(cls, key: str) -> Any:
        """The active user of a token trusted without asking the database, else None."""
        hit = cls._cache.get(key)
        return hit[1] if hit is not None and hit[0] > time.monotonic() else None

    @classmethod
    def cached(cls, request: Any) -> bool:
        """Whether the request's token is known without asking the database."""
        scheme, _, key = request.META.get("HTTP_AUTHORIZATION", "").partition(" ")
        hit = cls._cache.get(key.strip()) if scheme.lower() == cls.keyword.lower() else None
        return hit is not None and hit[0] > time.monotonic()


@receiver(post_delete, sender=Token)
def _forget_deleted_token(sender: type, instance: Token, **kwargs: Any) -> None:
    CachedTokenAuthentication._cache.pop(instance.key, None)
