"""The unit (and the scale to it) of each plottable field, so every plot's value axis names one."""

from __future__ import annotations

import re
from typing import TypedDict

from robot import interface as ri


class Unit(TypedDict):
    unit: str
    scale: float


# (interface key, field) → unit and scale; then rules by a field's path for any topic.
_BY_TOPIC: dict[tuple[str, str], tuple[str, float]] = {
    ("battery_soc", "data"): ("%", 100.0),
    ("battery_voltage", "data"): ("V", 1.0),
    ("battery_recharge_state", "data"): ("state code", 1.0),
    ("motors_state", "data"): ("1 = on", 1.0),
    ("client_count", "data"): ("clients", 1.0),
    **{("emotional_state", f"current_{axis}"): ("−1 … 1", 1.0) for axis in ("pleasure", "arousal", "dominance")},
}
_BY_PATH: list[tuple[re.Pattern[str], str]] = [
    (re.compile(r"(^|\.)position\.[xyz]$"), "m"),
    (re.compile(r"(^|\.)orientation\.[xyzw]$"), "quaternion"),
    (re.compile(r"(^|\.)linear\.[xyz]$"), "m/s"),
    (re.compile(r"(^|\.)angular\.[xyz]$"), "rad/s"),
    (re.compile(r"(^|\.)stamp\.secs$"), "s"),
    (re.compile(r"(^|\.)stamp\.nsecs$"), "ns"),
    (re.compile(r"(^|\.)seq$"), "count"),
    (re.compile(r"(^|\.)(ranges\.\d+|range_min|range_max)$"), "m"),
    (re.compile(r"(^|\.)angle_(min|max|increment)$"), "rad"),
    (re.compile(r"(^|\.)(scan_time|time_increment)$"), "s"),
    (re.compile(r"(^|\.)covariance\.\d+$"), "variance"),
]


def unit_of(topic: str, field: str) -> Unit | None:
    names = {t.name: t.key for t in ri.topics()}
    known = _BY_TOPIC.get((names.get(topic, ""), field))
    if known is not None:
        return {"unit": known[0], "scale": known[1]}
    for pattern, unit in _BY_PATH:
        if pattern.search(field):
            return {"unit": unit, "scale": 1.0}
    return None


def units_of(topic: str, fields: list[str]) -> dict[str, Unit]:
    """The fields of ``topic`` whose unit is known."""
    return {f: u for f in fields if (u := unit_of(topic, f)) is not None}


def unit_rules() -> dict[str, object]:
    """The same table for a page that plots any topic live (the Topics page applies it, static/js/plotaxes.js)."""
    names = {t.key: t.name for t in ri.topics()}
    topics: dict[str, dict[str, Unit]] = {}
    for (key, field), (unit, scale) in _BY_TOPIC.items():
        topics.setdefault(names[key], {})[field] = {"unit": unit, "scale": scale}
    return {"topics": topics, "paths": [[pattern.pattern, unit] for pattern, unit in _BY_PATH]}
