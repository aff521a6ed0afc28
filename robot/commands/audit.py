"""The audit trail: every command anyone sent to the robot, and what came of it."""

from __future__ import annotations

from typing import Any

from cyborg_site.client_address import client_address
from cyborg_site.text import scrub, scrub_json
from robot.models import AuditEntry


def audit_record(
    *, user: Any, source: str, action: str, params: dict[str, Any], ok: bool, outcome: str = "", error_code: str = "",
    address: str | None = None,
) -> AuditEntry:
    """``address``: the client's, when written away from its request (the audit writer's thread)."""
    authenticated = user is not None and getattr(user, "is_authenticated", False)
    return AuditEntry.objects.create(
        user_id=user.pk if authenticated else None,  # (an E-STOP pass user is not a model instance)
        username=user.get_username() if authenticated else "",
        source=source,
        action=action,
        # Text as it came (the robot's, or refused input) is kept readable and storable.
        params=scrub_json(params),
        ok=ok,
        outcome=scrub(outcome[:2000]),
        error_code=error_code,
        address=client_address.get() if address is None else address,
    )
