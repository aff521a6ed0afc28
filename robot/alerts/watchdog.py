"""The one alert no link can raise: that no link runs. Scaled, the Celery worker checks it.

Every alert is raised where the link runs, so when every link process is dead nothing would
tell anyone that the robot is now unwatched (its E-STOP path, its alerts, its recording). The
beat runs ``check_links`` every ``LINK_WATCH_EVERY_S``: once the link's last heartbeat is older
than ``LINK_DOWN_ALERT_S`` the ``link_down`` alert is kept and sent to whoever chose that kind,
once per outage (its id comes from the dead link's last heartbeat, so two checks, or two
workers, make one alert), and shown on every page's alert strip; a link that runs again ends it.
"""

from __future__ import annotations

import asyncio
import logging
import time
import uuid
from datetime import UTC, datetime

from django.conf import settings
from django.db import IntegrityError

from robot.alerts import delivery, records
from robot.alerts.book import Record
from robot.alerts.models import LINK_DOWN, Alert
from robot.live.announce import aget_state, apublish_state
from robot.live.groups import ALERTS_KEY
from robot.live.state import link_status

log = logging.getLogger(__name__)

KEY = LINK_DOWN
TEXT = "No robot link runs: the server cannot reach the robot, and no other alert can be raised"
_OUTAGES = uuid.UUID("6c1b2d0e-57a4-4e0b-9a39-5f3f3f1e7a10")
_first_seen_down: float | None = None  # when no link ever reported since Redis started


def check_links(now: float | None = None) -> str | None:
    """Raise, keep or end the ``link_down`` alert; returns what it did ("raised", "ended") or None."""
    global _first_seen_down
    now = now or time.time()
    status = link_status()
    if status.get("link_running"):
        _first_seen_down = None
        ended = Alert.objects.filter(key=KEY, ended_at=None).update(
            ended_at=datetime.fromtimestamp(now, UTC), updated_at=datetime.fromtimestamp(now, UTC))
        return "ended" if ended else None
    since = float(status.get("link_alive") or 0) or (_first_seen_down := _first_seen_down or now)
    if now - since < settings.LINK_DOWN_ALERT_S:
        return None
    record = Record(key=KEY, kind=KEY, severity="critical", text=TEXT, started_at=since, updated_at=now,
                    id=uuid.uuid5(_OUTAGES, f"{since:.6f}").hex)
    try:
        _, created = Alert.objects.get_or_create(id=record.id, defaults=records.row(record))
    except IntegrityError:  # another worker kept it first
        created = False
    if created:
        log.error("%s (last heard %.0f s ago)", TEXT, now - since)
        asyncio.run(_show_and_send(record, delivery.recipients(record.kind, record.severity)))
    return "raised" if created else None


async def _show_and_send(record: Record, targets: list[delivery.Target]) -> None:
    """Every page's alert strip shows it beside what the last raiser left there, until a raiser runs
    again and shows its own; and it goes to whoever chose it."""
    shown = (await aget_state(ALERTS_KEY)).get(ALERTS_KEY, {}).get("alerts", [])
    await apublish_state(ALERTS_KEY, {"alerts": [record.as_msg(), *(a for a in shown if a.get("key") != KEY)]})
    gate = asyncio.Semaphore(delivery.PARALLEL)
    await asyncio.gather(*(delivery.deliver(target, record, gate) for target in targets))
