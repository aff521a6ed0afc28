"""A person's access changed (a role taken away, the account deactivated or deleted, the password
changed, a logout): their open drive and audio sockets hear it at once, in every web process
(the channel layer), and close when they may no longer do what they were opened for. The page
then connects again with whatever access the person has now, or goes to the login page.

What every front-door tool may do changed (the admin's allowlist or paces, a topic marked sensitive):
every open front-door socket hears it the same way and reads its configuration again.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Awaitable, Callable
from typing import Any

from asgiref.sync import async_to_sync
from channels.db import database_sync_to_async
from channels.layers import get_channel_layer
from django.contrib.auth import HASH_SESSION_KEY, get_user_model, user_logged_out
from django.db import transaction
from django.db.models.signals import m2m_changed, post_delete, post_save
from django.dispatch import receiver

from cyborg_site.roles import is_operator
from dashboard.accounts import role_holders
from history.models import TopicPolicy
from robot.live.groups import FRONTDOOR_GROUP, person_group
from robot.models import FrontDoorAllowance, FrontDoorPace

log = logging.getLogger(__name__)

ACCESS_CHANGED = "access.changed"
RETRY_S = 1.0
FORBIDDEN = 4403  # the socket's close code: the person may no longer do this (the page reconnects)
LOGGED_OUT = 4401


def _tell(user_id: object, *, session_key: str = "") -> None:
    _tell_group(person_group(user_id), session_key=session_key)


def _tell_group(group: str, *, session_key: str = "") -> None:
    event = {"type": ACCESS_CHANGED, "session_key": session_key}
    transaction.on_commit(lambda: async_to_sync(_send)(group, event))


async def _send(group: str, event: dict[str, Any]) -> None:
    layer = get_channel_layer()
    if layer is not None:
        await layer.group_send(group, event)


@receiver([post_save, post_delete], sender=get_user_model())
def _saved_or_deleted(sender: type, instance: Any, created: bool = False, **kwargs: Any) -> None:
    if not created:
        _tell(instance.pk)


@receiver(m2m_changed, sender=get_user_model().groups.through)
def _groups_changed(sender: type, instance: Any, action: str, reverse: bool, pk_set: set[Any] | None,
                    **kwargs: Any) -> None:
    users = role_holders(instance, action, reverse, pk_set)  # (at pre_clear: the members the clear takes)
    if action.startswith("post_"):
        for user in users:
            _tell(user.pk)


@receiver([post_save, post_delete], sender=FrontDoorAllowance)
@receiver([post_save, post_delete], sender=FrontDoorPace)
@receiver([post_save, post_delete], sender=TopicPolicy)
def _frontdoor_configured(sender: type, **kwargs: Any) -> None:
    _tell_group(FRONTDOOR_GROUP)


@receiver(user_logged_out)
def _logged_out(sender: type, request: Any, user: Any, **kwargs: Any) -> None:
    if user is not None and request is not None and request.session.session_key:
        _tell(user.pk, session_key=request.session.session_key)


def sessions_ended(user_id: object, session_keys: list[str]) -> None:
    """Sessions deleted by an admin: their open sockets close as after a logout."""
    for key in session_keys:
        _tell(user_id, session_key=key)


def still_allowed(scope: dict[str, Any], *, operator: bool, session_key: str) -> int | None:
    """After an access change: the close code for this socket, or None if it may stay open.
    ``session_key``: the logout's (empty for any other change)."""
    session = scope.get("session")
    own_key = getattr(session, "session_key", None) or ""
    if session_key:
        return LOGGED_OUT if session_key == own_key else None
    user_id = getattr(scope.get("user"), "pk", None)
    fresh = get_user_model().objects.filter(pk=user_id, is_active=True).first() if user_id is not None else None
    if fresh is None:
        return LOGGED_OUT
    if session is not None and own_key and session.get(HASH_SESSION_KEY) not in (None, fresh.get_session_auth_hash()):
        return LOGGED_OUT  # the password changed: this session is no longer valid
    if operator and not is_operator(fresh):
        return FORBIDDEN
    return None


async def end_when_revoked(scope: dict[str, Any], *, operator: bool, end: Callable[[], Any]) -> None:
    """Until cancelled: hear the access changes of ``scope``'s person (as a socket does, through
    the channel layer) and ``end`` what they opened once they may no longer have it (a stream)."""
    layer = get_channel_layer()
    user_id = getattr(scope.get("user"), "pk", None)
    if layer is None or user_id is None:
        return
    group = person_group(user_id)
    while True:
        channel = ""
        try:
            channel = await layer.new_channel()
            await layer.group_add(group, channel)
            while True:
                event = await layer.receive(channel)
                if event.get("type") != ACCESS_CHANGED:
                    continue
                code = await database_sync_to_async(still_allowed)(scope, operator=operator,
                                                                   session_key=event.get("session_key", ""))
                if code is not None:
                    end()
                    return
        except Exception:  # the channel layer (Redis) is away: listen again once it is back
            log.warning("access changes of person %s unheard for now", user_id, exc_info=True)
            await asyncio.sleep(RETRY_S)
        finally:
            if channel:
                with contextlib.suppress(Exception):
                    await asyncio.shield(layer.group_discard(group, channel))


async def close_if_revoked(consumer: Any, event: dict[str, Any], *, operator: bool,
                           end: Callable[[], Awaitable[Any]]) -> bool:
    """A socket's answer to an access change: ``end`` what it does (driving, listening, talking) and
    close, if the person may no longer be here or do that (then True)."""
    code = await database_sync_to_async(still_allowed)(consumer.scope, operator=operator,
                                                       session_key=event.get("session_key", ""))
    if code is not None:
        await end()
        await consumer.close(code=code)
    return code is not None
