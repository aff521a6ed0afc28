"""Recording policies: what to record per topic, read as one snapshot, changed at run time."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from asgiref.sync import async_to_sync
from django.conf import settings
from django.db import transaction

from history.audio import is_audio_type
from history.models import Mode, RecordingSettings, TopicPolicy
from history.policy_audit import policies_audited
from robot.link.bus import acall_service


@dataclass(frozen=True)
class Policy:
    topic: str
    msg_type: str
    mode: str
    interval_s: float  # effective: the topic's own interval wins over the global default
    retention_s: float | None
    max_bytes: int


def effective_interval(own: float | None, default_s: float) -> float:
    return own if own is not None and own > 0 else default_s


def load_policies() -> dict[str, Policy]:
    """Every topic's effective policy (topics without a row are not recorded)."""
    default_s = RecordingSettings.load().effective_interval_s
    return {
        p.topic: Policy(
            topic=p.topic, msg_type=p.msg_type, mode=p.mode,
            interval_s=effective_interval(p.interval_s, default_s),
            retention_s=p.retention_s,
            max_bytes=p.max_message_bytes or settings.HISTORY_MAX_MESSAGE_BYTES,
        )
        for p in TopicPolicy.objects.all()
    }


def policy_upsert(*, topic: str, **fields: object) -> TopicPolicy:
    """Create or change one topic's policy; only the given fields change."""
    policy, _ = TopicPolicy.objects.get_or_create(topic=topic, defaults={"msg_type": fields.get("msg_type") or ""})
    for name, value in fields.items():
        setattr(policy, name, value)
    policy.full_clean()
    policy.save()
    return policy


def default_interval_set(*, seconds: float) -> RecordingSettings:
    row = RecordingSettings.load()
    row.default_interval_s = seconds
    row.save()
    return row


@transaction.atomic
def policies_add_discovered(*, topics: Iterable[tuple[str, str]], mode: str = Mode.OFF) -> list[str]:
    """Add a policy for each discovered (name, type) that has none yet; return the names added.

    Audio topics are added switched off whatever the mode: people's voices are recorded only
    when an admin turns that one topic on.
    """
    known = set(TopicPolicy.objects.values_list("topic", flat=True))
    new = [TopicPolicy(topic=name, msg_type=msg_type, mode=Mode.OFF if is_audio_type(msg_type) else mode)
           for name, msg_type in topics if name not in known]
    TopicPolicy.objects.bulk_create(new, ignore_conflicts=True)
    return [p.topic for p in new]


def policies_discover(*, user: Any, source: str, mode: str = Mode.OFF) -> tuple[int, list[str]]:
    """Add a policy (audited) for every topic the robot reports through /rosapi/topics; returns how
    many it reported and the names added. A robot that cannot answer raises ``RobotError``."""
    reply = async_to_sync(acall_service)("rosapi_topics") or {}
    pairs = list(zip(reply.get("topics", []), reply.get("types", []), strict=False))
    with policies_audited(user=user, source=source, topics=[name for name, _ in pairs]):
        added = policies_add_discovered(topics=pairs, mode=mode)
    return len(pairs), added
