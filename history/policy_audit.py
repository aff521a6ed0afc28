"""Every change to what is recorded is audited: who changed which topic's recording policy (or
the default interval) from what to what, in the admin or through the API. Recording the
microphone is a decision about people's voices; the trail says who made it."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from history.models import RecordingSettings, TopicPolicy
from robot.commands.audit import audit_record

POLICY_FIELDS = ("mode", "interval_s", "retention_s", "max_message_bytes", "sensitive")


def policies_now(topics: Iterable[str]) -> dict[str, dict[str, Any]]:
    """Each topic's policy fields as they stand (a topic with no policy is left out)."""
    return {row.pop("topic"): row for row in TopicPolicy.objects.filter(topic__in=list(topics))
            .values("topic", *POLICY_FIELDS)}


def audit_policies(*, user: Any, source: str, before: dict[str, dict[str, Any]],
                   after: dict[str, dict[str, Any]]) -> None:
    """One audit entry per topic whose policy changed (added, edited or removed)."""
    for topic in sorted(set(before) | set(after)):
        was, now = before.get(topic), after.get(topic)
        if was == now:
            continue
        what = "added" if was is None else "removed" if now is None else "changed"
        audit_record(user=user, source=source, action="history.policy", ok=True,
                     params={"topic": topic, "from": was, "to": now},
                     outcome=f"recording policy of {topic} {what}" + (f": {now['mode']}" if now else ""))


def default_interval_now() -> float:
    return RecordingSettings.load().default_interval_s


def audit_default_interval(*, user: Any, source: str, before: float, after: float) -> None:
    if before != after:
        audit_record(user=user, source=source, action="history.default_interval", ok=True,
                     params={"from": before, "to": after}, outcome=f"default recording interval {after:g} s")
