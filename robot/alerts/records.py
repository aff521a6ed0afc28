"""Alerts in the database: their history, written by the raiser, acknowledged from any web process."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

from django.contrib.auth.models import User

from robot.alerts.book import Record
from robot.alerts.models import LINK_DOWN, Alert


def _when(t: float | None) -> datetime | None:
    return datetime.fromtimestamp(t, UTC) if t is not None else None


def _epoch(d: datetime | None) -> float | None:
    return d.timestamp() if d is not None else None


def row(record: Record) -> dict[str, Any]:
    """The alert's columns as it is now (its acknowledgement only once there is one)."""
    return {"key": record.key, "kind": record.kind, "severity": record.severity, "text": record.text,
            "started_at": _when(record.started_at), "updated_at": _when(record.updated_at),
            "ended_at": _when(record.ended_at), "count": record.count,
            **({"acked_at": _when(record.acked_at), "acked_by_name": record.acked_by} if record.acked_at else {})}


def save(record: Record) -> None:
    """Write the alert as it is now (idempotent: the same record twice is one row)."""
    Alert.objects.update_or_create(id=record.id, defaults=row(record))


def open_records() -> list[Record]:
    """The alerts not ended, as the raiser keeps them (a new raiser takes them over); ``link_down`` is
    the worker's own (robot.alerts.watchdog), which a link only ends by running."""
    return [Record(key=a.key, kind=a.kind, severity=a.severity, text=a.text, started_at=a.started_at.timestamp(),
                   updated_at=a.updated_at.timestamp(), event=a.kind in ("log", "bumper"), count=a.count,
                   acked_by=a.acked_by_name, acked_at=_epoch(a.acked_at), id=a.id.hex)
            for a in Alert.objects.filter(ended_at=None).exclude(key=LINK_DOWN)]


def acknowledge(*, alert_id: str, user: User, at: float) -> Alert | None:
    """Mark an alert acknowledged by ``user`` (the first acknowledgement stands); None if there is none."""
    alert = Alert.objects.filter(id=alert_id).first()
    if alert is None:
        return None
    if alert.acked_at is None:
        alert.acked_at, alert.acked_by, alert.acked_by_name = _when(at), user, user.get_username()
        alert.save(update_fields=["acked_at", "acked_by", "acked_by_name"])
    return alert


def as_dict(alert: Alert) -> dict[str, Any]:
    return {"id": alert.id.hex, "key": alert.key, "kind": alert.kind, "severity": alert.severity,
            "text": alert.text, "started_at": alert.started_at.timestamp(),
            "updated_at": alert.updated_at.timestamp(), "ended_at": _epoch(alert.ended_at), "count": alert.count,
            "acked_by": alert.acked_by_name, "acked_at": _epoch(alert.acked_at)}
