"""A person's own address for alerts by e-mail: kept once they open the link mailed to it, so alerts
go only to an address its owner has shown they read (or to the account's, which an admin or the
sign-in provider set). The link is signed (Django's TimestampSigner), not stored: it names the person,
the address and the one it replaces, so it stops counting once another address is chosen."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from django.core import signing
from django.core.exceptions import ValidationError as DjangoValidationError
from django.core.mail import send_mail
from django.core.validators import validate_email
from rest_framework import serializers

from robot.alerts.models import AlertChoice

SALT = "robot.alerts.address"
LINK_HOURS = 24


def _own(user: Any) -> str:
    return AlertChoice.objects.filter(user=user).values_list("email", flat=True).first() or ""


def alert_address_request(*, user: Any, address: str, link: Callable[[str], str]) -> None:
    """Mail a link to ``address`` that makes it ``user``'s address for alerts once opened;
    ``link(token)`` gives the link's URL."""
    address = address.strip()
    try:
        validate_email(address)
    except DjangoValidationError:
        raise serializers.ValidationError({"email": ["not an e-mail address"]}) from None
    token = signing.dumps({"user": user.pk, "email": address, "was": _own(user)}, salt=SALT)
    try:
        send_mail("[Cyborg] Confirm your address for alerts",
                  f"Open this link to get Cyborg Commander's alerts at {address}:\n\n{link(token)}\n\n"
                  f"It works for {LINK_HOURS} hours. If you did not ask for this, ignore this mail.\n",
                  None, [address], fail_silently=False)
    except OSError as exc:
        raise serializers.ValidationError({"email": [f"the mail could not be sent ({exc}); try again later"]}) \
            from exc


def alert_address_verify(*, user: Any, token: str) -> str:
    """Keep the address a mailed link names as ``user``'s address for alerts; returns it."""
    try:
        data = signing.loads(token, salt=SALT, max_age=LINK_HOURS * 3600)
    except signing.SignatureExpired:
        raise serializers.ValidationError({"email": ["this link has expired: ask for a new one"]}) from None
    except signing.BadSignature:
        raise serializers.ValidationError({"email": ["this link is broken: copy all of it from the mail"]}) from None
    if data.get("user") != user.pk:
        raise serializers.ValidationError({"email": ["this link is for another account: sign in as its owner"]})
    if data.get("was") != _own(user):
        raise serializers.ValidationError({"email": ["your address for alerts has changed since this link was "
                                                     "sent: it no longer counts"]})
    AlertChoice.objects.update_or_create(user=user, defaults={"email": data["email"]})
    return str(data["email"])


def alert_address_forget(*, user: Any) -> None:
    """Alerts by e-mail go to the account's address again (and stop if it has none)."""
    choice = AlertChoice.objects.filter(user=user).first()
    if choice is not None:
        choice.email = ""
        choice.by_email = choice.by_email and bool(user.email)
        choice.save(update_fields=["email", "by_email"])
