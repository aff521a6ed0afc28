"""Topics for operators only: sound (the microphone and the speaker, whatever topic carries it)
and any topic an admin marks sensitive. Viewers are refused them on every path that shows a
topic's messages: the topics page, history, plots and exports."""

from __future__ import annotations

import threading
import time
from typing import Any

from django.db.models import Q

from cyborg_site.roles import is_operator
from history.models import TopicPolicy
from robot import interface as ri


def sensitive_topics() -> set[str]:
    recorded = TopicPolicy.objects.filter(Q(sensitive=True) | Q(msg_type__in=ri.SOUND_TYPES))
    return {*recorded.values_list("topic", flat=True), *(t.name for t in ri.topics() if t.type in ri.SOUND_TYPES)}


_recent: tuple[float, set[str]] = (float("-inf"), set())
_recent_lock = threading.Lock()


def recent_sensitive_topics(max_age_s: float) -> set[str]:
    """``sensitive_topics()`` as this process read it at most ``max_age_s`` ago (one query a while
    for all the open sockets that look again)."""
    global _recent
    with _recent_lock:
        read_at, topics = _recent
        if time.monotonic() - read_at > max_age_s:
            _recent = (time.monotonic(), topics := sensitive_topics())
        return topics


def refused_topics(user: Any, topics: list[str], *, max_age_s: float = 0.0) -> list[str]:
    """Those of ``topics`` that ``user`` may not read (a query only for a non-operator, none when
    this process read the sensitive topics less than ``max_age_s`` ago)."""
    if is_operator(user):
        return []
    sensitive = recent_sensitive_topics(max_age_s) if max_age_s else sensitive_topics()
    return [topic for topic in topics if topic in sensitive]


def refusal(topic: str) -> str:
    return f"{topic} is for operators only (sound, or marked sensitive by an admin)"
