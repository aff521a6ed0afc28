"""Per-user page preferences: which map overlays a person has switched on."""

from __future__ import annotations

from typing import Any

from django.contrib.auth.models import AnonymousUser, User
from rest_framework import serializers

from dashboard.models import UserPreference
from robot.live.keys import MAP_OVERLAY_KEYS

MAP_OVERLAYS = "map_overlays"
# The page's names for the overlays (the live keys behind them are robot.live.keys').
OVERLAY_NAMES: dict[str, str] = {key.removeprefix("overlay_"): key for key in MAP_OVERLAY_KEYS}
DEFAULT_OVERLAYS: dict[str, bool] = dict.fromkeys(OVERLAY_NAMES, False)


def map_overlays(user: User | AnonymousUser) -> dict[str, bool]:
    """Each overlay's on/off for ``user`` (all off until they choose)."""
    chosen: dict[str, Any] = {}
    if user.is_authenticated:
        row = UserPreference.objects.filter(user=user, name=MAP_OVERLAYS).first()
        chosen = row.value if row is not None and isinstance(row.value, dict) else {}
    return {name: bool(chosen.get(name, default)) for name, default in DEFAULT_OVERLAYS.items()}


def set_map_overlays(user: User | AnonymousUser, changes: dict[str, Any]) -> dict[str, bool]:
    """Switch some overlays on or off; names and values are checked, the rest stays as it was."""
    for name, value in changes.items():
        if name not in OVERLAY_NAMES:
            raise serializers.ValidationError(
                {str(name): [f"unknown overlay; the overlays are {', '.join(OVERLAY_NAMES)}"]})
        if not isinstance(value, bool):
            raise serializers.ValidationError({name: ["must be true or false"]})
    merged = {**map_overlays(user), **changes}
    UserPreference.objects.update_or_create(user=user, name=MAP_OVERLAYS, defaults={"value": merged})
    return merged


THEME = "theme"
# "system" follows the browser's prefers-color-scheme; "light" and "dark" override it for this person.
THEMES = ("system", "light", "dark")


def theme(user: User | AnonymousUser) -> str:
    """The colour theme ``user`` chose ("system" until they choose)."""
    if not user.is_authenticated:
        return "system"
    row = UserPreference.objects.filter(user=user, name=THEME).first()
    value = row.value.get("theme") if row is not None and isinstance(row.value, dict) else None
    return value if value in THEMES else "system"


def set_theme(user: User | AnonymousUser, value: Any) -> str:
    if value not in THEMES:
        raise serializers.ValidationError({"theme": [f"must be one of {', '.join(THEMES)}"]})
    UserPreference.objects.update_or_create(user=user, name=THEME, defaults={"value": {"theme": value}})
    return str(value)
