"""Incidents: what makes one (pure checks of robot messages), opening, listing and releasing them."""

from __future__ import annotations

import time
from typing import Any

from django.conf import settings
from django.db import transaction

from history.models import CameraFrame, Incident
from history.storage import utc
from robot import interface as ri
from robot.alerts.rules import LOG_ERROR, pressed_bumpers
from robot.models import AuditEntry

# The black box's topics: those the triggers read, and those an incident keeps every message of
# (when the admin records them every N seconds; the default policies cover them all).
BLACKBOX_KEYS = (
    "robot_pose", "odom", "amcl_pose", "plan", "move_base_status", "state_change", "robot_mode",
    "emotional_state", "battery_soc", "bumper_state", "motors_state", "diagnostics", "rosout",
)
# The topics the triggers read (the black box hears them whatever their recording policy).
TRIGGER_KEYS = ("bumper_state", "rosout", "diagnostics")
MAX_TRIGGERS = 50
DRIVE_ACTIONS = ("teleop.lock", "teleop.takeover", "teleop.unlock", "estop")


class Triggers:
    """Edge detection on the robot's messages: a pressed bumper, an ERROR/FATAL line, a
    diagnostics status entering ERROR. ``check`` returns (kind, summary) or None."""

    def __init__(self) -> None:
        self._bumped = False
        self._diag_errors: set[str] = set()
        self._names = {ri.topic(key).name: key for key in TRIGGER_KEYS}

    def check(self, name: str, msg: dict[str, Any]) -> tuple[str, str] | None:
        key = self._names.get(name)
        if key == "rosout":
            level = msg.get("level")
            if isinstance(level, int) and level >= LOG_ERROR:
                text = f"{ri.LOG_LEVELS.get(level, level)} {msg.get('name', '')}: {msg.get('msg', '')}"
                return Incident.Kind.LOG_ERROR, text[:300]
        elif key == "bumper_state":
            pressed = pressed_bumpers(msg)
            was, self._bumped = self._bumped, bool(pressed)
            if pressed and not was:
                return Incident.Kind.BUMPER, f"{' and '.join(pressed)} bumper pressed"
        elif key == "diagnostics":
            errors = {str(s.get("name")): str(s.get("message", "")) for s in msg.get("status") or ()
                      if s.get("level") == ri.DIAGNOSTIC_ERROR}
            new = sorted(set(errors) - self._diag_errors)
            # Components may report in separate arrays: an array without a name says nothing of it.
            reported = {str(s.get("name")) for s in msg.get("status") or ()}
            self._diag_errors = (self._diag_errors - reported) | set(errors)
            if new:
                return Incident.Kind.DIAGNOSTICS, "; ".join(f"{n}: {errors[n]}" for n in new)[:300]
        return None


def driver_at(t: float) -> str:
    """Who held the drive lock at ``t``, from the audit log ('' when nobody)."""
    last = (AuditEntry.objects.filter(action__in=DRIVE_ACTIONS, ok=True, created__lte=utc(t))
            .order_by("-created", "-id").values_list("action", "username").first())
    return last[1] if last and last[0] in ("teleop.lock", "teleop.takeover") else ""


@transaction.atomic
def incident_open(*, kind: str, t: float, summary: str = "", by: str = "") -> Incident:
    """A new incident around ``t``, or, when one of the same kind is still open then, that one
    with this trigger added (an ERROR line repeated every second makes one incident)."""
    same = (Incident.objects.select_for_update().filter(kind=kind, t__lte=t, end__gte=t)
            .order_by("-t").first())
    if same is not None:
        if len(same.triggers) < MAX_TRIGGERS:
            same.triggers = [*same.triggers, {"t": t, "summary": summary, "by": by}]
            same.save(update_fields=["triggers"])
        return same
    return Incident.objects.create(
        kind=kind, t=t, start=t - settings.INCIDENT_BEFORE_S, end=t + settings.INCIDENT_AFTER_S,
        summary=summary[:300], by=by, driver=driver_at(t),
    )


def incidents_to_capture(*, now: float | None = None) -> list[Incident]:
    """Incidents still being captured; those whose window has passed are closed on the way."""
    now = now or time.time()
    Incident.objects.filter(complete=False, end__lt=now).update(complete=True)
    return list(Incident.objects.filter(complete=False))


def incident_release(*, incident: Incident, by: str) -> Incident:
    """An admin lets retention have it (its samples and frames go with their topics' ages)."""
    incident.held = False
    incident.released_by = by
    incident.save(update_fields=["held", "released_by"])
    return incident


def incident_thumbnail(incident: Incident) -> CameraFrame | None:
    """The frame of the moment itself (the newest at or before it)."""
    return (CameraFrame.objects.filter(t__lte=incident.t, t__gte=incident.start).order_by("-t").first()
            or CameraFrame.objects.filter(t__gte=incident.t, t__lte=incident.end).order_by("t").first())

