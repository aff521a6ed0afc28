"""Reads for the plots page and the API: recorded topics, plottable fields, state timeline."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

from history.models import Mode, Sample, TopicPolicy
from history.rollup import numeric_leaves
from history.storage import utc
from robot import interface as ri


def numeric_fields(msg: Any) -> list[str]:
    """Dotted paths of the numeric and boolean leaves of a message (all of them, rolled up or not)."""
    return [path for path, _ in numeric_leaves(msg)]


def latest_sample(topic: str) -> Sample | None:
    return Sample.objects.filter(topic=topic).order_by("-received_at").first()


def recorded_topics() -> list[dict[str, Any]]:
    """Topics with a policy or with samples kept under one, newest sample first-class."""
    out = []
    for policy in TopicPolicy.objects.all():
        last = latest_sample(policy.topic)
        if last is None and policy.mode == Mode.OFF:
            continue
        out.append({
            "topic": policy.topic, "msg_type": policy.msg_type, "mode": policy.mode,
            "last": last.received_at if last else None,
            "fields": numeric_fields(last.data) if last else [],
        })
    return out


@dataclass
class Timeline:
    start: float
    end: float
    segments: list[dict[str, Any]] = field(default_factory=list)  # {"state", "start", "end"}
    totals: dict[str, float] = field(default_factory=dict)  # seconds per state


def state_timeline(*, start: datetime, end: datetime, now: float | None = None) -> Timeline:
    """Time spent per state-machine state between start and end, from recorded state changes."""
    topic = ri.topic("state_change").name
    t0, t1 = start.timestamp(), min(end.timestamp(), now or time.time())
    before = (
        Sample.objects.filter(topic=topic, received_at__lt=start).order_by("-received_at")
        .values_list("received_at", "data").first()
    )
    changes = list(
        Sample.objects.filter(topic=topic, received_at__gte=start, received_at__lt=utc(t1))
        .order_by("received_at", "id").values_list("received_at", "data")
    )
    timeline = Timeline(start=t0, end=t1)
    state = before[1].get("to_system_state") if before else None
    since = t0
    for received_at, data in changes:
        at = received_at.timestamp()
        if state is None:
            state = data.get("from_system_state") or None
        _close(timeline, state, since, at)
        state, since = data.get("to_system_state") or None, at
    _close(timeline, state, since, t1)
    return timeline


def _close(timeline: Timeline, state: str | None, start: float, end: float) -> None:
    if state is None or end <= start:
        return
    timeline.segments.append({"state": state, "start": start, "end": end})
    timeline.totals[state] = timeline.totals.get(state, 0.0) + (end - start)
