"""The alerts that are on now, kept by the one process that raises them (where the link runs).

Plain data and plain methods: each returns the change it made (raised, updated, ended, acked) so
the engine can show, keep and deliver it; nothing here waits on anything.
"""

from __future__ import annotations

import uuid
from dataclasses import asdict, dataclass, field, replace
from typing import Any, Literal

from robot.alerts.rules import Signal

What = Literal["raised", "updated", "ended", "acked"]


@dataclass
class Record:
    key: str
    kind: str
    severity: str
    text: str
    started_at: float
    updated_at: float
    event: bool = False
    count: int = 1
    ended_at: float | None = None
    acked_by: str = ""
    acked_at: float | None = None
    id: str = field(default_factory=lambda: uuid.uuid4().hex)

    def as_msg(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class Change:
    what: What
    record: Record


class AlertBook:
    def __init__(self, *, event_quiet_s: float = 600.0) -> None:
        self.event_quiet_s = event_quiet_s
        self.active: dict[str, Record] = {}

    def load(self, records: list[Record]) -> None:
        """Alerts still open when the last raiser stopped: they keep their id and start."""
        for record in records:
            self.active.setdefault(record.key, record)

    def apply(self, signal: Signal, now: float) -> Change | None:
        known = self.active.get(signal.key)
        if not signal.on:
            return self._end(known, now) if known is not None else None
        if known is None:
            record = Record(signal.key, signal.kind, signal.severity, signal.text, signal.at or now, now,
                            event=signal.event)
            self.active[signal.key] = record
            return Change("raised", record)
        if signal.event:
            if signal.at and signal.at < known.updated_at - 1:
                return None  # an older line (a replay) than the one shown
            known.count += 1
        elif (known.severity, known.text) == (signal.severity, signal.text):
            return None
        known.severity, known.text, known.updated_at = signal.severity, signal.text, now
        return Change("updated", known)

    def end_missing(self, prefix: str, on: set[str], now: float) -> list[Change]:
        """End every alert under ``prefix`` whose key is not in ``on`` (a component that recovered)."""
        gone = [k for k in self.active if k.startswith(prefix) and k not in on]
        return [c for k in gone if (c := self._end(self.active[k], now)) is not None]

    def expire(self, now: float) -> list[Change]:
        """Events with no repeat for ``event_quiet_s`` end."""
        quiet = [r for r in self.active.values() if r.event and now - r.updated_at > self.event_quiet_s]
        return [c for r in quiet if (c := self._end(r, now)) is not None]

    def ack(self, alert_id: str, by: str, at: float) -> Change | None:
        for record in self.active.values():
            if record.id == alert_id:
                if record.acked_at is None:
                    record.acked_by, record.acked_at = by, at
                # An acknowledged event is done with; a condition stays until it clears.
                return self._end(record, at) if record.event else Change("acked", record)
        return None

    def _end(self, record: Record, now: float) -> Change:
        del self.active[record.key]
        return Change("ended", replace(record, ended_at=now))

    def snapshot(self) -> dict[str, Any]:
        """What every page shows: the alerts on now, newest first."""
        ordered = sorted(self.active.values(), key=lambda r: r.started_at, reverse=True)
        return {"alerts": [r.as_msg() for r in ordered]}
