"""Reads for the plots page and the API: recorded topics, plottable fields, state timeline."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

from django.db import connection

from history.models import Mode, Sample, TopicPolicy
from history.rollup import numeric_leaves
from history.sessions import OFFLINE, SESSION_TOPIC
from history.storage import utc
from robot import interface as ri


def numeric_fields(msg: Any) -> list[str]:
    """Dotted paths of the numeric and boolean leaves of a message (all of them, rolled up or not)."""
    return [path for path, _ in numeric_leaves(msg)]


def recorded_topics() -> list[dict[str, Any]]:
    """Topics with a policy or with samples kept under one, newest sample first-class."""
    out = []
    for policy in TopicPolicy.objects.all():
        last = Sample.objects.filter(topic=policy.topic).order_by("-received_at").first()
        if last is None and policy.mode == Mode.OFF:
            continue
        data = last.data if last else None  # no sample: no fields, no text
        out.append({"topic": policy.topic, "msg_type": policy.msg_type, "mode": policy.mode,
                    "last": last.received_at if last else None, "fields": numeric_fields(data), "text": has_text(data)})
    return out


def has_text(msg: Any) -> bool:
    """Does the message carry text worth reading (a String, a log line, a state change)? Headers don't count."""
    if isinstance(msg, str):
        return True
    if isinstance(msg, dict):
        return any(has_text(v) for k, v in msg.items() if k != "header")
    return False


def recorded_messages(*, topic: str, start: datetime, end: datetime, limit: int) -> tuple[list[dict[str, Any]], bool]:
    """Up to ``limit`` messages of ``topic`` in [start, end), newest first, and whether there were more."""
    rows = list(
        Sample.objects.filter(topic=topic, received_at__gte=start, received_at__lt=end)
        .order_by("-received_at", "-id").values_list("received_at", "data")[: limit + 1]
    )
    return [{"t": at.timestamp(), "data": data} for at, data in rows[:limit]], len(rows) > limit


# No sample of any topic for this long: the robot (or the recorder) was away, and the time
# is nobody's state. Wider than the slowest default periodic interval.
GAP_S = 120.0
_PRECISION_S = 0.001  # SQLite's julianday() times are only this exact
_EPOCH = {
    "postgresql": "extract(epoch FROM received_at)::float8",
    "sqlite": "(julianday(received_at) - 2440587.5) * 86400.0",
}


@dataclass
class Timeline:
    start: float
    end: float
    segments: list[dict[str, Any]] = field(default_factory=list)  # {"state", "start", "end"}
    totals: dict[str, float] = field(default_factory=dict)  # seconds per state
    counts: dict[str, int] = field(default_factory=dict)  # times each state was entered
    spans: list[tuple[float, float]] = field(default_factory=list)  # when data was recorded at all


def recorded_spans(t0: float, t1: float, gap_s: float = GAP_S) -> list[tuple[float, float]]:
    """The stretches of [t0, t1] covered by samples of any topic, no two samples further than
    ``gap_s`` apart; a stretch reaching to within ``gap_s`` of an edge runs on to it."""
    width = gap_s / 2
    sql = (f"SELECT floor(e / %s), min(e), max(e) FROM (SELECT {_EPOCH[connection.vendor]} AS e"
           f" FROM {Sample._meta.db_table} WHERE received_at >= %s AND received_at < %s) z GROUP BY 1 ORDER BY 1")
    adapt = connection.ops.adapt_datetimefield_value
    with connection.cursor() as cursor:
        cursor.execute(sql, [width, adapt(utc(t0 - gap_s)), adapt(utc(t1))])
        buckets = [(float(lo), float(hi)) for _, lo, hi in cursor.fetchall()]
    spans: list[list[float]] = []
    for lo, hi in buckets:
        if spans and lo - spans[-1][1] <= gap_s:
            spans[-1][1] = hi
        else:
            spans.append([lo, hi])
    clipped = [(max(lo, t0), t1 if t1 - hi <= gap_s else min(t1, hi)) for lo, hi in spans]
    return [(lo, hi) for lo, hi in clipped if hi > lo]


def state_timeline(*, start: datetime, end: datetime, now: float | None = None) -> Timeline:
    """Time spent per state-machine state between start and end, from recorded state changes,
    counting only the time the recording covers (a robot that ran ten minutes shows ten minutes).
    While the link had lost the robot the time is "offline"; after it came back the state is the one
    the robot's next transition left (a restarted robot's ``startup``), never the one before."""
    topic = ri.topic("state_change").name
    t0, t1 = start.timestamp(), min(end.timestamp(), now or time.time())
    topics = [topic, SESSION_TOPIC]
    before = [row for name in topics for row in Sample.objects.filter(topic=name, received_at__lt=start)
              .order_by("-received_at").values_list("received_at", "topic", "data")[:1]]
    events = sorted(before) + list(
        Sample.objects.filter(topic__in=topics, received_at__gte=start, received_at__lt=utc(t1))
        .order_by("received_at", "id").values_list("received_at", "topic", "data")
    )
    timeline = Timeline(start=t0, end=t1, spans=recorded_spans(t0, t1))
    state: str | None = None
    since = t0
    for received_at, name, data in events:
        at = max(received_at.timestamp(), t0)
        if name == SESSION_TOPIC:
            if data.get("connected"):
                _close(timeline, state, since, at)
                state, since = None, at  # unknown until the robot's next transition
            elif state != OFFLINE:
                _close(timeline, state, since, at)
                state, since = OFFLINE, at
            continue
        if state is None:
            state = data.get("from_system_state") or None
        _close(timeline, state, since, at)
        state, since = data.get("to_system_state") or None, at
    _close(timeline, state, since, t1)
    return timeline


def _close(timeline: Timeline, state: str | None, start: float, end: float) -> None:
    """Count [start, end] in ``state``, where the recording covers it."""
    if state is None:
        return
    for lo, hi in timeline.spans:
        lo, hi = max(lo, start), min(hi, end)
        if hi - lo < _PRECISION_S:
            continue
        last = timeline.segments[-1] if timeline.segments else None
        if last is not None and last["state"] == state and last["end"] == lo:
            last["end"] = hi
        else:
            timeline.segments.append({"state": state, "start": lo, "end": hi})
            if last is None or last["state"] != state:
                timeline.counts[state] = timeline.counts.get(state, 0) + 1
        timeline.totals[state] = timeline.totals.get(state, 0.0) + (hi - lo)
