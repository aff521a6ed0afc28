"""Write recorded rows fast, and keep the downsampling cache honest about late rows.

Plain ``bulk_create`` tops out near 10,000 rows/s; the recorder must sustain more, so rows
(already JSON text) go in with one ``executemany`` on SQLite and ``COPY`` on PostgreSQL.
"""

from __future__ import annotations

import asyncio
import json
import logging
import math
import time
from collections import defaultdict
from collections.abc import Callable, Sequence
from datetime import UTC, datetime
from typing import Any, TypeVar

from django.db import close_old_connections, connection, transaction
from django.db.models import BigIntegerField, ExpressionWrapper, F

from history.models import Sample, SeriesBucket

log = logging.getLogger(__name__)
T = TypeVar("T")

# (topic, msg_type, receive time in epoch seconds, message as JSON text)
Row = tuple[str, str, float, str]
# The same with the message still a dict.
Pending = tuple[str, str, dict[str, Any], float]

# Buckets newer than this may still get rows (batches in flight, periodic samples); never cached.
SETTLE_S = 10.0

_TABLE = Sample._meta.db_table
_COLUMNS = "topic, msg_type, received_at, data"


class FailureLog:
    """Log a repeating background failure once, and its recovery, instead of every retry."""

    def __init__(self, what: str) -> None:
        self.what = what
        self.failing = False

    def ok(self) -> None:
        if self.failing:
            log.warning("history: %s works again", self.what)
            self.failing = False

    def failed(self) -> None:
        if not self.failing:
            log.exception("history: %s failed; retrying quietly until it works", self.what)
            self.failing = True


async def in_thread(fn: Callable[..., T], *args: Any, **kwargs: Any) -> T:
    """Run blocking database work off the event loop, in a worker thread that tidies its connection."""

    def call() -> T:
        close_old_connections()
        try:
            return fn(*args, **kwargs)
        finally:
            close_old_connections()

    return await asyncio.to_thread(call)


def utc(t: float) -> datetime:
    return datetime.fromtimestamp(t, tz=UTC)


def encode(pending: Sequence[Pending], limits: dict[str, int], *, default_max: int) -> tuple[list[Row], int]:
    """Messages as JSON rows; oversize ones are left out with a warning. Returns (rows, oversize count)."""
    rows: list[Row] = []
    oversize = 0
    for topic, msg_type, msg, t in pending:
        text = json.dumps(msg, separators=(",", ":"), ensure_ascii=False)
        limit = limits.get(topic, default_max)
        size = len(text.encode()) if len(text) * 4 > limit else len(text)
        if size > limit:
            oversize += 1
            log.warning("history: not storing a %d-byte message on %s (limit %d bytes)", size, topic, limit)
            continue
        rows.append((topic, msg_type, t, text))
    return rows, oversize


def write_rows(rows: Sequence[Row]) -> int:
    """Store rows in one transaction; returns how many were stored."""
    if not rows:
        return 0
    with transaction.atomic():
        if connection.vendor == "postgresql":
            with connection.cursor() as cursor, cursor.copy(f"COPY {_TABLE} ({_COLUMNS}) FROM STDIN") as copy:
                for topic, msg_type, t, text in rows:
                    copy.write_row((topic, msg_type, utc(t), text))
        elif connection.vendor == "sqlite":
            adapt = connection.ops.adapt_datetimefield_value
            with connection.cursor() as cursor:
                cursor.executemany(
                    f"INSERT INTO {_TABLE} ({_COLUMNS}) VALUES (%s, %s, %s, %s)",
                    [(topic, msg_type, adapt(utc(t)), text) for topic, msg_type, t, text in rows],
                )
        else:
            Sample.objects.bulk_create(
                Sample(topic=tp, msg_type=mt, received_at=utc(t), data=json.loads(tx)) for tp, mt, t, tx in rows
            )
        _forget_late_buckets(rows)
    return len(rows)


def _forget_late_buckets(rows: Sequence[Row]) -> None:
    horizon = time.time() - SETTLE_S
    spans: dict[str, list[float]] = defaultdict(lambda: [float("inf"), float("-inf")])
    for topic, _, t, _ in rows:
        if t < horizon:
            span = spans[topic]
            span[0], span[1] = min(span[0], t), max(span[1], t)
    for topic, (lo, hi) in spans.items():
        forget_buckets(topic=topic, start_ms=lo * 1000, end_ms=hi * 1000)


def forget_buckets(*, topic: str, start_ms: float | None = None, end_ms: float | None = None) -> int:
    """Drop cached buckets of ``topic`` that overlap [start_ms, end_ms]."""
    big = BigIntegerField()
    buckets = SeriesBucket.objects.filter(topic=topic).alias(
        b_start=ExpressionWrapper(F("index") * F("width_ms"), output_field=big),
        b_end=ExpressionWrapper((F("index") + 1) * F("width_ms"), output_field=big),
    )
    if start_ms is not None:
        buckets = buckets.filter(b_end__gt=math.floor(start_ms))
    if end_ms is not None:
        buckets = buckets.filter(b_start__lte=math.ceil(end_ms))
    return buckets.delete()[0]
