"""Reading alerts: the ones on now (the raiser's latest word) and their history."""

from __future__ import annotations

from typing import Any

from robot.alerts import records
from robot.alerts.models import LINK_DOWN, Alert
from robot.live.groups import ALERTS_KEY
from robot.live.state import get_store


async def alerts_on() -> list[dict[str, Any]]:
    """The raiser's alerts, and the worker's ``link_down`` while no raiser runs."""
    entry = (await get_store().aget_many([ALERTS_KEY])).get(ALERTS_KEY)
    shown = [a for a in (entry or {}).get("msg", {}).get("alerts", []) if a.get("key") != LINK_DOWN]
    unraised = [records.as_dict(a) async for a in Alert.objects.filter(key=LINK_DOWN, ended_at=None)]
    return [*shown, *unraised]


def alerts_history(*, limit: int = 100, kind: str = "") -> list[dict[str, Any]]:
    rows = Alert.objects.all()
    if kind:
        rows = rows.filter(kind=kind)
    return [records.as_dict(a) for a in rows[:limit]]
