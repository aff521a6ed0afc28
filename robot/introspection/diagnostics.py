"""``/diagnostics`` by component: the latest status each component reported, and when.

A ``DiagnosticArray`` may carry every component or only some (each node publishes its own),
so components are kept apart by name and merged across messages. Plain functions on plain data.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from robot import interface as ri

# A component not heard of for this long is dropped from the table (the robot stopped naming it).
FORGET_AFTER_S = 600.0
MAX_TEXT = 500
MAX_VALUES = 64


@dataclass(frozen=True)
class Component:
    name: str
    level: int
    message: str
    hardware_id: str
    values: tuple[tuple[str, str], ...]
    t: float  # when the server received it (epoch s)

    @property
    def level_name(self) -> str:
        return ri.DIAGNOSTIC_LEVELS.get(self.level, str(self.level))

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "level": self.level, "level_name": self.level_name, "message": self.message,
                "hardware_id": self.hardware_id, "values": [list(kv) for kv in self.values], "t": self.t}


def _text(value: Any) -> str:
    return str(value if value is not None else "")[:MAX_TEXT]


def components_from_message(msg: Mapping[str, Any], t: float) -> list[Component]:
    """The statuses of one ``DiagnosticArray``; entries without a name are skipped."""
    out = []
    for status in msg.get("status") or []:
        if not isinstance(status, Mapping) or not status.get("name"):
            continue
        try:
            level = int(status.get("level", 0))
        except (TypeError, ValueError):
            level = ri.DIAGNOSTIC_STALE
        pairs = (status.get("values") or [])[:MAX_VALUES]
        values = tuple((_text(kv.get("key")), _text(kv.get("value"))) for kv in pairs if isinstance(kv, Mapping))
        out.append(Component(_text(status["name"]), level, _text(status.get("message")),
                             _text(status.get("hardware_id")), values, t))
    return out


def merge(known: Mapping[str, Component], new: Iterable[Component], *, now: float) -> dict[str, Component]:
    """``known`` updated with ``new``, less components not heard of for ``FORGET_AFTER_S``."""
    merged = {name: c for name, c in known.items() if now - c.t <= FORGET_AFTER_S}
    for c in new:
        merged[c.name] = c
    return merged


def changed_levels(before: Mapping[str, Component], after: Mapping[str, Component]) -> bool:
    """Whether a component appeared, vanished, or changed its level or message."""
    if before.keys() != after.keys():
        return True
    return any((before[n].level, before[n].message) != (after[n].level, after[n].message) for n in after)


def summary(components: Mapping[str, Component]) -> dict[str, Any]:
    """What the pages show: every component by name, and the worst level reported."""
    ordered = sorted(components.values(), key=lambda c: c.name)
    worst = max((c.level for c in ordered if c.level in ri.DIAGNOSTIC_LEVELS), default=ri.DIAGNOSTIC_OK)
    return {"components": [c.as_dict() for c in ordered], "worst": worst,
            "worst_name": ri.DIAGNOSTIC_LEVELS[worst]}
