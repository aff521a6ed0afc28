"""A person's own sessions: each browser they signed in from (a SessionRecord made at login), which
they can see and end. Ending one deletes it from Django's session store, and its open sockets close
as after a logout (dashboard.revocation)."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from datetime import timedelta
from typing import Any

from django.contrib.auth import SESSION_KEY, user_logged_in, user_logged_out
from django.contrib.sessions.models import Session
from django.db import DatabaseError
from django.dispatch import receiver
from django.http import HttpRequest, HttpResponseBase
from django.utils import timezone
from rest_framework import serializers

from dashboard.models import SessionRecord
from dashboard.revocation import sessions_ended

SEEN_EVERY = timedelta(minutes=5)  # how often a session's "last seen" is written, at most
_SEEN_KEY = "_seen"


@receiver(user_logged_in)
def _logged_in(sender: type, request: HttpRequest | None, user: Any, **kwargs: Any) -> None:
    if request is not None and request.session.session_key:
        key = request.session.session_key
        SessionRecord.objects.update_or_create(session_key=key, defaults={
            "user": user, "address": request.META.get("REMOTE_ADDR", "")[:45],
            "user_agent": request.META.get("HTTP_USER_AGENT", "")[:300]})


@receiver(user_logged_out)
def _logged_out(sender: type, request: HttpRequest | None, user: Any, **kwargs: Any) -> None:
    if request is not None and request.session.session_key:
        SessionRecord.objects.filter(session_key=request.session.session_key).delete()


def session_seen(request: HttpRequest) -> None:
    """Note that this signed-in session was used now (written once per ``SEEN_EVERY``)."""
    now = timezone.now()
    seen = request.session.get(_SEEN_KEY)
    if seen is None or now.timestamp() - seen >= SEEN_EVERY.total_seconds():
        request.session[_SEEN_KEY] = now.timestamp()
        SessionRecord.objects.filter(session_key=request.session.session_key).update(last_seen=now)


class SessionSeenMiddleware:
    """Keeps each signed-in session's "last seen" for its person's account page."""

    def __init__(self, get_response: Callable[[HttpRequest], HttpResponseBase]) -> None:
        self.get_response = get_response

    def __call__(self, request: HttpRequest) -> HttpResponseBase:
        response = self.get_response(request)
        # Only a session the request read anyway: no query of its own, and none at all for the
        # E-STOP's way while the database is down (a read that failed in the view fails here again).
        if request.session.accessed:
            with contextlib.suppress(DatabaseError):
                if request.session.get(SESSION_KEY):
                    session_seen(request)
        return response


def session_rekeyed(*, old_key: str, new_key: str) -> None:
    """The session kept its person under a new key (a password change cycles it)."""
    if old_key and new_key and old_key != new_key:
        SessionRecord.objects.filter(session_key=old_key).update(session_key=new_key)


def sessions_of(*, user: Any) -> list[SessionRecord]:
    """The person's sessions that still last, newest first (records of ended ones are let go)."""
    live = set(Session.objects.filter(session_key__in=SessionRecord.objects.filter(user=user).values("session_key"),
                                      expire_date__gt=timezone.now()).values_list("session_key", flat=True))
    SessionRecord.objects.filter(user=user).exclude(session_key__in=live).delete()
    return list(SessionRecord.objects.filter(user=user))




def session_end(*, user: Any, record_id: Any, current_key: str) -> None:
    """End one of the person's other sessions (this one ends with Log out)."""
    records = SessionRecord.objects.filter(user=user, pk=int(record_id) if str(record_id).isdigit() else 0)
    if not records.exists():
        raise serializers.ValidationError("No such session of yours: it may have ended already.")
    if records.filter(session_key=current_key).exists():
        raise serializers.ValidationError("This is the session you are using: log out to end it.")
    key = records.get().session_key
    Session.objects.filter(session_key=key).delete()
    records.delete()
    sessions_ended(user.pk, [key])


def sessions_end_others(*, user: Any, current_key: str) -> int:
    """End every session of the person but this one, recorded or not (made before records were kept);
    how many ended."""
    recorded = SessionRecord.objects.filter(user=user).values_list("session_key", flat=True)
    keys = set(session_keys_of(user)) | set(recorded)
    keys.discard(current_key)
    Session.objects.filter(session_key__in=keys).delete()
    SessionRecord.objects.filter(session_key__in=keys).delete()
    sessions_ended(user.pk, sorted(keys))
    return len(keys)


def end_sessions_and_tokens(user: Any) -> tuple[int, int]:
    """Log ``user`` out everywhere at once: every session (their open sockets close) and every API
    token. Returns how many of each ended."""
    from rest_framework.authtoken.models import Token

    keys = session_keys_of(user)
    Session.objects.filter(session_key__in=keys).delete()
    tokens, _ = Token.objects.filter(user=user).delete()
    sessions_ended(user.pk, keys)
    return len(keys), tokens


def session_keys_of(user: Any) -> list[str]:
    """The keys of ``user``'s sessions that still last (Django's store has no index by person: each is read)."""
    return [session.session_key for session in Session.objects.filter(expire_date__gt=timezone.now()).iterator()
            if session.get_decoded().get(SESSION_KEY) == str(user.pk)]
