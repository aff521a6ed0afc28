"""Acknowledging an alert: from any web process, kept in the database, shown by the raiser."""

from __future__ import annotations

import logging
import time
import uuid
from typing import Any

from asgiref.sync import async_to_sync
from django.contrib.auth.models import AnonymousUser, User
from rest_framework.exceptions import NotFound, PermissionDenied

from cyborg_site.roles import is_operator
from robot.alerts import records
from robot.link.bus import RobotError, arequest

log = logging.getLogger(__name__)


def _alert_id(raw: str) -> str:
    try:
        return uuid.UUID(str(raw)).hex
    except ValueError:
        raise NotFound("No such alert.") from None


def alert_acknowledge(*, user: User | AnonymousUser, alert_id: str) -> dict[str, Any]:
    """Operators and admins acknowledge; the first acknowledgement stands (who, when). The raiser shows it
    on every page; an alert raised a moment ago, not kept yet, the raiser keeps acknowledged."""
    if not is_operator(user) or not isinstance(user, User):
        raise PermissionDenied("Only operators and admins acknowledge alerts.")
    key, at = _alert_id(alert_id), time.time()
    alert = records.acknowledge(alert_id=key, user=user, at=at)
    kept = records.as_dict(alert) if alert is not None else None
    by, at = (kept["acked_by"], kept["acked_at"]) if kept is not None else (user.get_username(), at)
    shown = async_to_sync(atell_raiser)(alert_id=key, by=by, at=at)
    if kept is not None:
        return kept
    if shown is None:
        raise NotFound("No such alert.")
    return shown


async def atell_raiser(*, alert_id: str, by: str, at: float) -> dict[str, Any] | None:
    """The raiser shows the acknowledgement on every page and answers the alert as it holds it; an alert
    that has ended meanwhile is no error."""
    try:
        reply = await arequest("alert_ack", args={"id": alert_id, "by": by, "at": at}, timeout=1)
    except RobotError as exc:
        log.info("the acknowledgement of %s is kept but not shown live: %s", alert_id, exc.message)
        return None
    shown = reply.get("values")
    return {k: v for k, v in shown.items() if k != "event"} if shown else None  # the API's shape
