"""What raises an alert: plain functions from what the robot said (or did not say) to signals.

A signal turns an alert on or off. A condition (offline, battery low, a bumper) lasts while it
holds; an event (an ERROR line) is one occurrence: repeats count, and it ends after a quiet spell.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from robot import interface as ri
from robot.introspection.diagnostics import Component

LOG_ERROR = 8
LOG_FATAL = 16


@dataclass(frozen=True)
class Signal:
    key: str  # one alert per key while it lasts: "battery_low", "log:/node", "diag:name"
    kind: str  # robot.alerts.models.KINDS
    on: bool
    severity: str = "warning"
    text: str = ""
    at: float = 0.0  # when it began (epoch s); 0: when it was noticed
    event: bool = False


def battery(msg: Mapping[str, Any], *, low_percent: float) -> Signal:
    try:
        percent = float(msg.get("data", 1.0)) * 100
    except (TypeError, ValueError):
        percent = 100.0
    return Signal("battery_low", "battery_low", percent < low_percent,
                  "critical" if percent < low_percent / 2 else "warning", f"Battery low: {percent:.0f} %")


def pressed_bumpers(msg: Mapping[str, Any]) -> list[str]:
    return [side for side in ("front", "rear") if any(msg.get(f"{side}_bumpers") or [])]


def bumper(pressed: list[str], t: float) -> Signal:
    """A press is an event (a bump lasts a blink; the alert stays until acknowledged), raised as it begins."""
    return Signal("bumper", "bumper", True, "warning", f"Bumper pressed: {' and '.join(pressed)}", at=t, event=True)


def log_line(msg: Mapping[str, Any], t: float) -> Signal | None:
    try:
        level = int(msg.get("level", 0))
    except (TypeError, ValueError):
        return None
    if level < LOG_ERROR:
        return None
    name = str(msg.get("name") or "?")
    stamp = msg.get("header", {}).get("stamp") if isinstance(msg.get("header"), Mapping) else None
    at = t
    if isinstance(stamp, Mapping) and stamp.get("secs"):
        at = float(stamp["secs"]) + float(stamp.get("nsecs", 0)) / 1e9
    level_name = ri.LOG_LEVELS.get(level, str(level))
    return Signal(f"log:{name}", "log", True, "critical" if level >= LOG_FATAL else "error",
                  f"{level_name} from {name}: {str(msg.get('msg', ''))[:500]}", at=at, event=True)


def link(*, connected: bool, offline_for: float, responding: bool, grace_s: float) -> list[Signal]:
    """Offline once it has been for ``grace_s`` (a reconnect's blink is no alert); not responding at once
    (the link already waited ``ROBOT_HANG_S`` before saying so)."""
    return [
        Signal("offline", "offline", not connected and offline_for >= grace_s, "error",
               "Robot offline: no connection to the robot"),
        Signal("not_responding", "not_responding", connected and not responding, "error",
               "Robot not responding: connected, but it has said nothing for a while"),
    ]


def estop(*, latched: bool, by: str, at: float) -> Signal:
    return Signal("estop", "estop", latched, "critical", f"E-STOP engaged by {by or 'someone'}", at=at)


_DIAG_SEVERITY = {ri.DIAGNOSTIC_WARN: "warning", ri.DIAGNOSTIC_ERROR: "error", ri.DIAGNOSTIC_STALE: "warning"}


def diagnostics(components: Iterable[Component], *, now: float, stale_after_s: float) -> list[Signal]:
    """A signal on for every component reporting WARN, ERROR or STALE, or not heard of for
    ``stale_after_s`` (then STALE, whatever it said last): the level is kept current."""
    out = []
    for c in components:
        silent = now - c.t
        if silent > stale_after_s:
            level, detail = ri.DIAGNOSTIC_STALE, f"not heard of for over {stale_after_s:g} s"
        else:
            level, detail = c.level, c.message or "no message"
        if level in _DIAG_SEVERITY:
            name = ri.DIAGNOSTIC_LEVELS[level]
            out.append(Signal(f"diag:{c.name}", "diagnostics", True, _DIAG_SEVERITY[level],
                              f"{c.name}: {name} · {detail}"))
    return out
