"""The one writer: recorded rows fast with their rollups, and camera frames, in one transaction.

Plain ``bulk_create`` tops out near 10,000 rows/s; the recorder must sustain more, so rows
(already JSON text) go in with one ``executemany`` on SQLite and ``COPY`` on PostgreSQL.
The numeric rollups of the same rows (``history.rollup``) are merged in with one upsert
per (topic, field, second or minute) in the same transaction, so they never disagree.
"""

from __future__ import annotations

import asyncio
import json
import logging
import math
from collections.abc import Callable, Sequence
from datetime import UTC, datetime
from typing import Any

from django.db import close_old_connections, connection, transaction

from cyborg_site.text import scrub
from history.frames import Frame, write_frames
from history.models import Rollup, Sample
from history.rollup import LEVELS_S, Aggregates, aggregate
from robot.live.state import jsonable
from robot.supervisor import spawn

log = logging.getLogger(__name__)

# (topic, msg_type, receive time in epoch seconds, message as JSON text[, the same message parsed])
# The recorder passes the parsed message along so the rollups need no second parse.
Row = tuple[str, str, float, str] | tuple[str, str, float, str, Any]
# The same with the message still a dict.
Pending = tuple[str, str, dict[str, Any], float]
# What the recorder's one buffer holds (messages and camera frames), and what its writer is given.
Taken = Pending | Frame
Item = Row | Frame

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

    def failed(self, reason: str = "") -> None:
        """Log the failure being handled (a reason: one line, for a failure that needs no traceback)."""
        if not self.failing:
            if reason:
                log.warning("history: %s failed (%s); retrying quietly until it works", self.what, reason)
            else:
                log.exception("history: %s failed; retrying quietly until it works", self.what)
            self.failing = True

    async def attempt[T](self, fn: Callable[..., T], *args: Any) -> T | None:
        """``fn(*args)`` in a worker thread (``in_thread``); None when it failed (logged once per outage)."""
        try:
            result = await in_thread(fn, *args)
        except Exception:
            self.failed()
            return None
        self.ok()
        return result


IN_FLIGHT_WAIT_S = 10.0


async def in_thread[T](fn: Callable[..., T], *args: Any, **kwargs: Any) -> T:
    """Run blocking database work off the event loop, in a worker thread that tidies its connection."""

    def call() -> T:
        close_old_connections()
        try:
            return fn(*args, **kwargs)
        finally:
            close_old_connections()

    work = spawn(asyncio.to_thread(call), awaited=True)
    try:
        return await asyncio.shield(work)
    except asyncio.CancelledError:
        # A thread cannot be stopped: a service that is cancelled ends once its write has, so what
        # follows (shutdown, a test's database teardown) never meets the database mid-write.
        done, _ = await asyncio.wait({work}, timeout=IN_FLIGHT_WAIT_S)
        for finished in done:
            if not finished.cancelled():
                finished.exception()  # nobody waits for its outcome any more: don't report it as lost
        raise


def newest_samples(topics: Sequence[str]) -> dict[str, float]:
    """Each topic's newest stored sample time (epoch seconds; 0 when none)."""
    newest = (Sample.objects.filter(topic=topic).order_by("-received_at").values_list("received_at", flat=True)
              .first() for topic in topics)
    return {topic: at.timestamp() if at else 0.0 for topic, at in zip(topics, newest, strict=True)}


def utc(t: float) -> datetime:
    return datetime.fromtimestamp(t, tz=UTC)


def encode(pending: Sequence[Pending], limits: dict[str, int], *, default_max: int) -> tuple[list[Row], int]:
    """Messages as JSON rows; oversize ones are left out with a warning. Returns (rows, oversize count)."""
    rows: list[Row] = []
    oversize = 0
    for topic, msg_type, msg, t in pending:
        # scrub: a lone surrogate from the robot would not encode for the database.
        text = scrub(json.dumps(msg, separators=(",", ":"), ensure_ascii=False, default=jsonable))
        limit = limits.get(topic, default_max)
        size = len(text.encode()) if len(text) * 4 > limit else len(text)
        if size > limit:
            oversize += 1
            log.warning("history: not storing a %d-byte message on %s (limit %d bytes)", size, topic, limit)
            continue
        rows.append((topic, msg_type, t, text, msg))
    return rows, oversize


def write_batch(items: Sequence[Item]) -> int:
    """The recorder's writer: its messages (as rows) and frames in one transaction; returns how many."""
    frames: list[Frame] = []
    rows: list[Row] = []
    for item in items:
        if len(item) == 3:
            frames.append(item)
        else:
            rows.append(item)
    if not frames:
        return write_rows(rows)
    with transaction.atomic():
        return write_frames(sorted(frames, key=lambda frame: frame[0])) + write_rows(rows)


def write_rows(rows: Sequence[Row]) -> int:
    """Store rows in one transaction; returns how many were stored."""
    if not rows:
        return 0
    with transaction.atomic():
        if connection.vendor == "postgresql":
            with connection.cursor() as cursor, cursor.copy(f"COPY {_TABLE} ({_COLUMNS}) FROM STDIN") as copy:
                for row in rows:
                    copy.write_row((row[0], row[1], utc(row[2]), row[3]))
        else:  # SQLite, the one other database history runs on
            adapt = connection.ops.adapt_datetimefield_value
            with connection.cursor() as cursor:
                cursor.executemany(
                    f"INSERT INTO {_TABLE} ({_COLUMNS}) VALUES (%s, %s, %s, %s)",
                    [(row[0], row[1], adapt(utc(row[2])), row[3]) for row in rows],
                )
        write_rollups(aggregate((r[0], r[2], r[4] if len(r) > 4 else json.loads(r[3])) for r in rows))
    return len(rows)


_ROLLUP_COLUMNS = "topic, level_s, field, slot, t_first, vmin, vmax, vsum, n"
_ROLLUP_TYPES = ("text", "integer", "text", "bigint", "float8", "float8", "float8", "float8", "integer")


def _rollup_upsert(vendor: str) -> str:
    table = Rollup._meta.db_table
    if vendor == "postgresql":
        # One statement for the whole batch: executemany costs a round trip per row.
        arrays = ", ".join(f"%s::{kind}[]" for kind in _ROLLUP_TYPES)
        rows, least, greatest = f"SELECT * FROM unnest({arrays})", "least", "greatest"
    else:
        rows, least, greatest = "VALUES (%s, %s, %s, %s, %s, %s, %s, %s, %s)", "min", "max"
    return (
        f"INSERT INTO {table} ({_ROLLUP_COLUMNS}) {rows}"
        " ON CONFLICT (topic, level_s, field, slot) DO UPDATE SET"
        f" t_first = {least}({table}.t_first, excluded.t_first), vmin = {least}({table}.vmin, excluded.vmin),"
        f" vmax = {greatest}({table}.vmax, excluded.vmax), vsum = {table}.vsum + excluded.vsum,"
        f" n = {table}.n + excluded.n"
    )


def write_rollups(aggregates: Aggregates) -> None:
    """Merge rollups into the stored ones (inside the caller's transaction)."""
    if not aggregates:
        return
    # In key order, so concurrent writers (Celery workers) lock rows in the same order: no deadlocks.
    rows = [(*key, *aggregates[key]) for key in sorted(aggregates)]
    with connection.cursor() as cursor:
        if connection.vendor == "postgresql":
            cursor.execute(_rollup_upsert("postgresql"), [list(column) for column in zip(*rows, strict=True)])
        else:
            cursor.executemany(_rollup_upsert("sqlite"), rows)  # type: ignore[arg-type]  # floats and strs


def samples_deleted(*, topic: str, start: float | None, end: float) -> None:
    """Recompute ``topic``'s rollup slots overlapping [start, end] from its samples, after some were deleted."""
    with transaction.atomic():
        for level in LEVELS_S:
            hi = math.floor(end / level) + 1
            rollups = Rollup.objects.filter(topic=topic, level_s=level, slot__lt=hi)
            samples = Sample.objects.filter(topic=topic, received_at__lt=utc(hi * level))
            if start is not None:
                lo = math.floor(start / level)
                rollups, samples = rollups.filter(slot__gte=lo), samples.filter(received_at__gte=utc(lo * level))
            rollups.delete()
            kept = samples.values_list("received_at", "data").iterator(chunk_size=2000)
            write_rollups(aggregate(((topic, at.timestamp(), data) for at, data in kept), levels=(level,)))
