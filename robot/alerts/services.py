"""Acknowledging an alert: from any web process, kept in the database, shown by the raiser."""

from __future__ import annotations

import logging
import time
import uuid
from typing import Any

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
    """Operators and admins acknowledge; the first acknowledgement stands (who, when)."""
    if not is_operator(user) or not isinstance(user, User):
        raise PermissionDenied("Only operators and admins acknowledge alerts.")
    at = time.time()
    alert = records.acknowledge(alert_id=_alert_id(alert_id), user=user, at=at)
    if alert is None:
        raise NotFound("No such alert.")
    return records.as_dict(alert)


async def atell_raiser(*, alert_id: str, by: str, at: float) -> None:
    """The raiser shows the acknowledgement on every page; an alert that has ended meanwhile is no error."""
    try:
        await arequest("alert_ack", args={"id": uuid.UUID(alert_id).hex, "by": by, "at": at}, timeout=1)
    except RobotError as exc:
        log.info("the acknowledgement of %s is kept but not shown live: %s", alert_id, exc.message)
