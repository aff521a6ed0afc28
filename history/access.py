"""Topics for operators only: sound (the microphone and the speaker, whatever topic carries it)
and any topic an admin marks sensitive. Viewers are refused them on every path that shows a
topic's messages: the topics page, history, plots and exports."""

from __future__ import annotations

from typing import Any

from django.db.models import Q

from cyborg_site.roles import is_operator
from history.models import TopicPolicy
from robot import interface as ri


def sensitive_topics() -> set[str]:
    recorded = TopicPolicy.objects.filter(Q(sensitive=True) | Q(msg_type__in=ri.SOUND_TYPES))
    return {*recorded.values_list("topic", flat=True), *(t.name for t in ri.topics() if t.type in ri.SOUND_TYPES)}


def refused_topics(user: Any, topics: list[str]) -> list[str]:
    """Those of ``topics`` that ``user`` may not read (a query only for a non-operator)."""
    if is_operator(user):
        return []
    sensitive = sensitive_topics()
    return [topic for topic in topics if topic in sensitive]


def refusal(topic: str) -> str:
    return f"{topic} is for operators only (sound, or marked sensitive by an admin)"
