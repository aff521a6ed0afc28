"""What the E-STOP latch holds: who pressed it and when, what each step did, who released it.

The link writes it back itself when the shared store missed a press (Redis was out of reach),
so it lives below both the link and the commands."""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

from django.conf import settings
from django.utils import timezone


@dataclass(frozen=True)
class Latch:
    latched: bool
    by: str = ""
    at: float = 0.0  # epoch seconds of the press
    steps: list[dict[str, Any]] = field(default_factory=list)  # each {step, ok, detail}; empty while running
    released_by: str = ""
    released_at: float = 0.0

    @property
    def message(self) -> str:
        return f"E-STOP engaged by {self.by or 'an unknown user'} at {format_time(self.at)}"

    @property
    def failed_steps(self) -> list[dict[str, Any]]:
        return [s for s in self.steps if not s.get("ok")]

    def as_msg(self) -> dict[str, Any]:
        return {
            "latched": self.latched, "by": self.by, "at": self.at, "at_text": format_time(self.at) if self.at else "",
            "message": self.message if self.latched else "", "steps": self.steps,
            "released_by": self.released_by, "released_at": self.released_at,
        }

    @classmethod
    def from_msg(cls, msg: dict[str, Any] | None) -> Latch:
        if not msg:
            return RELEASED
        return cls(
            latched=bool(msg.get("latched")), by=str(msg.get("by") or ""), at=float(msg.get("at") or 0),
            steps=list(msg.get("steps") or []), released_by=str(msg.get("released_by") or ""),
            released_at=float(msg.get("released_at") or 0),
        )


RELEASED = Latch(latched=False)


def format_time(t: float) -> str:
    moment = datetime.fromtimestamp(t, tz=UTC)
    if settings.USE_TZ:
        moment = timezone.localtime(moment)
    return moment.strftime("%Y-%m-%d %H:%M:%S %Z").strip()
