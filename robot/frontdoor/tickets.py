"""Connect tickets: short-lived and single-use, so a URL a tool was given (and may log) is worth
nothing once used or after a few seconds. Only a hash is kept; redeeming is one atomic update, so
two processes cannot both let the same ticket in."""

from __future__ import annotations

import hashlib
import secrets
from datetime import timedelta
from typing import Any

from django.conf import settings
from django.utils import timezone

from cyborg_site.roles import load_roles
from robot.models import ConnectTicket


def _digest(raw: str) -> str:
    return hashlib.sha256(raw.encode()).hexdigest()


def ticket_issue(*, user: Any) -> str:
    """A new ticket for ``user`` (valid ``FRONTDOOR_TICKET_S`` seconds, once); old ones are swept."""
    now = timezone.now()
    ConnectTicket.objects.filter(expires__lt=now - timedelta(minutes=5)).delete()
    raw = secrets.token_urlsafe(32)
    ConnectTicket.objects.create(digest=_digest(raw), user=user,
                                 expires=now + timedelta(seconds=settings.FRONTDOOR_TICKET_S))
    return raw


def ticket_redeem(raw: str) -> Any | None:
    """The active user whose unused, unexpired ticket this is (its roles loaded), or None; the ticket
    is used up either way."""
    if not raw or len(raw) > 200:
        return None
    digest = _digest(raw)
    now = timezone.now()
    if not ConnectTicket.objects.filter(digest=digest, used__isnull=True, expires__gt=now).update(used=now):
        return None
    ticket = ConnectTicket.objects.select_related("user").get(digest=digest)
    user = ticket.user
    if not user.is_active:
        return None
    return load_roles(user)  # the role checks on the event loop then read no database
