"""What the robot looks like right now, for scripts: the latest value and age of everything
the dashboard shows, the link status, and the requested mode against the state reached."""

from __future__ import annotations

import json
import time
from collections.abc import Mapping
from typing import Any

from django.db.models import QuerySet

from robot import interface as ri
from robot.commands.modes import state_reached
from robot.live.groups import MODE_REQUEST_KEY, STATUS_KEY
from robot.live.keys import STATE_KEYS
from robot.live.state import get_store, status_view
from robot.models import AuditEntry


def available_events(entry: dict[str, Any] | None) -> dict[str, str]:
    """``state_transitions`` carries a JSON object {event: resulting state} as a string."""
    if not entry:
        return {}
    try:
        events = json.loads(entry["msg"].get("data") or "{}")
    except (ValueError, AttributeError):
        return {}
    return {str(k): str(v) for k, v in events.items()} if isinstance(events, dict) else {}


def mode_summary(request: dict[str, Any] | None, change: dict[str, Any] | None) -> dict[str, Any] | None:
    if not request:
        return None
    msg = request["msg"]
    state = (change or {}).get("msg", {}).get("to_system_state", "")
    return {**msg, "requested_at": request["t"], "state": state,
            "reached": state_reached(ri.Mode.from_short(msg["mode"]), state)}


async def arobot_state() -> dict[str, Any]:
    entries = await get_store().aget_many([STATUS_KEY, *STATE_KEYS])
    link = {k: v for k, v in status_view(entries.get(STATUS_KEY)).items() if k != "type"}
    now = time.time()
    values = {
        key: {"value": e["msg"], "age_s": round(now - float(e["t"]), 3), "t": e["t"]}
        for key in STATE_KEYS if (e := entries.get(key)) is not None
    }
    return {
        "connected": bool(link["connected"]),
        "command_path": bool(link["command_path"]),
        "link": link,
        "values": values,
        "available_events": available_events(entries.get("state_transitions")),
        "mode": mode_summary(entries.get(MODE_REQUEST_KEY), entries.get("state_change")),
    }


AUDIT_FILTERS = ("user", "action", "source", "outcome")


def audit_entries(filters: Mapping[str, str]) -> QuerySet[AuditEntry]:
    """The command log, newest first, narrowed by ?user= &action= &source= &outcome=ok|failed."""
    entries = AuditEntry.objects.all()
    for name, column in (("user", "username"), ("action", "action"), ("source", "source")):
        if value := filters.get(name, "").strip():
            entries = entries.filter(**{column: value})
    outcome = filters.get("outcome", "").strip()
    if outcome in ("ok", "failed"):
        entries = entries.filter(ok=outcome == "ok")
    return entries
