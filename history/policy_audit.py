"""Every change to what is recorded is audited: who changed which topic's recording policy (or
the default interval) from what to what, in the admin or through the API. Recording the
microphone is a decision about people's voices; the trail says who made it."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import Any

from history.models import RecordingSettings, TopicPolicy
from robot.commands.audit import audit_record

POLICY_FIELDS = ("mode", "interval_s", "retention_s", "max_message_bytes", "sensitive")


def policies_now(topics: Iterable[str]) -> dict[str, dict[str, Any]]:
    """Each topic's policy fields as they stand (a topic with no policy is left out)."""
    return {row.pop("topic"): row for row in TopicPolicy.objects.filter(topic__in=list(topics))
            .values("topic", *POLICY_FIELDS)}


@contextmanager
def policies_audited(*, user: Any, source: str, topics: Iterable[str]) -> Iterator[None]:
    """One audit entry per topic of ``topics`` whose policy the block changed (added, edited or removed)."""
    names = list(topics)
    before = policies_now(names)
    yield
    after = policies_now(names)
    for topic in sorted(set(before) | set(after)):
        was, now = before.get(topic), after.get(topic)
        if was == now:
            continue
        what = "added" if was is None else "removed" if now is None else "changed"
        audit_record(user=user, source=source, action="history.policy", ok=True,
                     params={"topic": topic, "from": was, "to": now},
                     outcome=f"recording policy of {topic} {what}" + (f": {now['mode']}" if now else ""))


@contextmanager
def default_interval_audited(*, user: Any, source: str) -> Iterator[None]:
    """An audit entry when the block changed the default interval."""
    before = RecordingSettings.load().default_interval_s
    yield
    after = RecordingSettings.load().default_interval_s
    if before != after:
        audit_record(user=user, source=source, action="history.default_interval", ok=True,
                     params={"from": before, "to": after}, outcome=f"default recording interval {after:g} s")
