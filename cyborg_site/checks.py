"""System checks of the site's own settings.

A placeholder or weak SECRET_KEY is an error wherever it could sign a production session: in every
`manage.py check` (and each command that runs the checks, migrate among them) with DEBUG off, and
in `check --deploy` always. Django's own check (security.W009) is only a deployment warning.
"""

from __future__ import annotations

from typing import Any

from django.conf import settings
from django.core import checks
from django.core.checks import CheckMessage
from django.core.exceptions import ImproperlyConfigured

MIN_LENGTH = 50
MIN_DISTINCT_CHARACTERS = 5
PLACEHOLDERS = ("change-me", "changeme", "change_me", "placeholder", "example", "secret-key")


def secret_key_problem(key: str) -> str | None:
    """Why ``key`` must not sign anything, or None."""
    if not key:
        return "it is empty"
    if len(key) < MIN_LENGTH:
        return f"it has {len(key)} characters, fewer than {MIN_LENGTH}"
    if len(set(key)) < MIN_DISTINCT_CHARACTERS:
        return f"it has fewer than {MIN_DISTINCT_CHARACTERS} different characters"
    if key.startswith("django-insecure-"):
        return "it is the one startproject wrote (django-insecure-…)"
    lowered = key.lower()
    for word in PLACEHOLDERS:
        if word in lowered:
            return f"it is a placeholder (it contains {word!r})"
    return None


def _errors() -> list[CheckMessage]:
    try:
        key = settings.SECRET_KEY
    except ImproperlyConfigured:  # Django's word for an empty one
        key = ""
    problem = secret_key_problem(key)
    if problem is None:
        return []
    return [checks.Error(f"SECRET_KEY cannot be used: {problem}.",
                         hint='Set SECRET_KEY to a new random value: python3 -c "import secrets; '
                              'print(secrets.token_urlsafe(50))"',
                         id="cyborg_site.E001")]


@checks.register(checks.Tags.security)
def check_secret_key(app_configs: Any, **kwargs: Any) -> list[CheckMessage]:
    return [] if settings.DEBUG else _errors()


@checks.register(checks.Tags.security, deploy=True)
def check_secret_key_for_deployment(app_configs: Any, **kwargs: Any) -> list[CheckMessage]:
    return _errors() if settings.DEBUG else []
