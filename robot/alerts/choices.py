"""Each person's choice of alerts beyond the tab, and the browsers they get Web Push in."""

from __future__ import annotations

import re
from typing import Any

from django.contrib.auth.models import AnonymousUser, User
from rest_framework import serializers

from cyborg_site.text import text_problem
from robot.alerts import push
from robot.alerts.models import KINDS, SEVERITY_RANK, AlertChoice, PushSubscription

FIELDS = ("by_email", "by_push", "kinds", "min_severity")
_BASE64URL = re.compile(r"[A-Za-z0-9_-]+={0,2}")


def _person(user: User | AnonymousUser) -> User:
    if not isinstance(user, User):
        raise serializers.ValidationError("Sign in first.")
    return user


def alert_choice(user: User | AnonymousUser) -> dict[str, Any]:
    person = _person(user)
    choice = AlertChoice.objects.filter(user=person).first() or AlertChoice(user=person)
    return {"by_email": choice.by_email, "by_push": choice.by_push, "kinds": list(choice.kinds),
            "min_severity": choice.min_severity, "email": choice.address, "kinds_available": KINDS,
            "push_public_key": push.public_key(), "push_browsers": PushSubscription.objects.filter(user=person).count()}


def alert_choice_set(user: User | AnonymousUser, changes: dict[str, Any]) -> dict[str, Any]:
    """Change some of by_email, by_push, kinds, min_severity; each checked, the rest as it was."""
    person = _person(user)
    unknown = set(changes) - set(FIELDS)
    if unknown:
        raise serializers.ValidationError({name: ["not a choice"] for name in sorted(unknown)})
    for name in ("by_email", "by_push"):
        if name in changes and not isinstance(changes[name], bool):
            raise serializers.ValidationError({name: ["must be true or false"]})
    if "kinds" in changes:
        kinds = changes["kinds"]
        if not isinstance(kinds, list) or not all(isinstance(k, str) and k in KINDS for k in kinds):
            raise serializers.ValidationError({"kinds": [f"a list of: {', '.join(KINDS)}"]})
        changes["kinds"] = sorted(set(kinds))
    if "min_severity" in changes and changes["min_severity"] not in SEVERITY_RANK:
        raise serializers.ValidationError({"min_severity": [f"one of: {', '.join(SEVERITY_RANK)}"]})
    if changes.get("by_email") and not (AlertChoice.objects.filter(user=person).first() or
                                        AlertChoice(user=person)).address:
        raise serializers.ValidationError({"by_email": ["no e-mail address: give yours on your account page"]})
    AlertChoice.objects.update_or_create(user=person, defaults=changes)
    return alert_choice(person)


def push_subscribe(user: User | AnonymousUser, data: dict[str, Any]) -> None:
    """Keep a browser's push subscription (as PushSubscription.toJSON() gives it) for this person."""
    person = _person(user)
    endpoint, keys = data.get("endpoint"), data.get("keys")
    if not isinstance(endpoint, str) or not endpoint.startswith(("https://", "http://")) or len(endpoint) > 1000:
        raise serializers.ValidationError({"endpoint": ["a push service URL"]})
    if text_problem(endpoint, limit=1000):
        raise serializers.ValidationError({"endpoint": [str(text_problem(endpoint, limit=1000))]})
    if not isinstance(keys, dict) or not all(isinstance(keys.get(k), str) and 0 < len(keys[k]) <= 200
                                             and _BASE64URL.fullmatch(keys[k]) for k in ("p256dh", "auth")):
        raise serializers.ValidationError({"keys": ["p256dh and auth, as the browser gives them (base64url)"]})
    PushSubscription.objects.update_or_create(endpoint=endpoint, defaults={
        "user": person, "p256dh": keys["p256dh"], "auth": keys["auth"]})


def push_unsubscribe(user: User | AnonymousUser, endpoint: Any) -> None:
    PushSubscription.objects.filter(user=_person(user), endpoint=str(endpoint)).delete()
