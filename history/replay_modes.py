"""The mode at a replayed moment: the one last requested (and by whom) and the one the state machine reached.

A request is kept where it was made: on the robot's ``robot_mode`` topic (the robot's commander, or this
server with ``MODE_COMMANDER=robot``) and in the audit log (every mode change and E-STOP people sent
from here; with the default ``MODE_COMMANDER=server`` nothing is published on ``robot_mode``). The mode
reached is read from the recorded state: the mode whose state the state machine was in.
"""

from __future__ import annotations

from typing import Any

from history.models import Sample
from history.storage import utc
from robot import interface as ri
from robot.commands.moderoute import in_behaviour
from robot.models import AuditEntry

# The replayed keys these add to a moment's topics and to a window's changes.
REQUEST_KEY = "mode_request"
REACHED_KEY = "mode_reached"
# Audited commands that request a mode: the E-STOP puts the robot in mode stop.
MODE_ACTIONS = ("mode", "estop")


def mode_name(value: object) -> str | None:
    """``manual`` for "manual", "manual control" or "MANUAL"; None for anything that is no mode."""
    try:
        return ri.Mode.from_short(str(value).strip().lower()).short
    except ValueError:
        return None


def reached_mode(state: str | None) -> str | None:
    """The mode whose state ``state`` is (any state inside the behaviour container is behaviour's)."""
    if not state:
        return None
    for mode, target in ri.MODE_TARGET_STATE.items():
        if state == target.value:
            return mode.short
    return ri.Mode.BEHAVIOUR.short if in_behaviour(state) else None


def reached(state_change: dict[str, Any] | None) -> dict[str, Any]:
    state = (state_change or {}).get("to_system_state") or ""
    return {"mode": reached_mode(state), "state": state}


def _from_audit(entry: AuditEntry) -> tuple[float, dict[str, Any]] | None:
    mode = ri.Mode.STOP.short if entry.action == "estop" else mode_name((entry.params or {}).get("mode"))
    if mode is None:
        return None
    return entry.created.timestamp(), {"mode": mode, "by": entry.username or "system", "ok": entry.ok,
                                       "outcome": "" if entry.ok else entry.outcome}


def _from_topic(t: float, msg: dict[str, Any]) -> tuple[float, dict[str, Any]] | None:
    mode = mode_name(msg.get("data"))
    return None if mode is None else (t, {"mode": mode, "by": "", "ok": True, "outcome": ""})


def requests(start: float, end: float, *, hidden: frozenset[str] = frozenset()) -> list[tuple[float, dict[str, Any]]]:
    """Every mode request in (start, end], in time order."""
    audited = AuditEntry.objects.filter(action__in=MODE_ACTIONS, created__gt=utc(start), created__lte=utc(end))
    found = [r for e in audited if (r := _from_audit(e)) is not None]
    topic = ri.topic("robot_mode").name
    if topic not in hidden:
        rows = Sample.objects.filter(topic=topic, received_at__gt=utc(start), received_at__lte=utc(end))
        found += [r for at, data in rows.values_list("received_at", "data")
                  if (r := _from_topic(at.timestamp(), data)) is not None]
    return sorted(found, key=lambda r: r[0])


def request_at(t: float, robot_mode: dict[str, Any] | None) -> dict[str, Any] | None:
    """The newest mode request at or before ``t``, as a replayed value {t, msg}; ``robot_mode`` is the
    topic's latest sample at ``t`` (already read with the moment's other topics)."""
    newest = [r for e in AuditEntry.objects.filter(action__in=MODE_ACTIONS, created__lte=utc(t))
              .order_by("-created", "-id")[:20] if (r := _from_audit(e)) is not None][:1]
    if robot_mode and (r := _from_topic(robot_mode["t"], robot_mode["msg"])) is not None:
        newest.append(r)
    if not newest:
        return None
    at, msg = max(newest, key=lambda r: r[0])
    return {"t": at, "msg": msg}
