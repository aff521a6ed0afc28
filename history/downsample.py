"""Downsampled series of one numeric field: min/max buckets computed in the database.

Buckets sit on a fixed grid (width from a ladder of round values, index = floor(epoch /
width)), Each bucket keeps its minimum and maximum, so spikes survive however far the series is
zoomed out.

Buckets of a second or wider are summed from the rollups written with the rows (one row per
field and minute, or second), so no JSON is read. Narrower buckets, and fields the rollups
leave out, come from the stored JSON, read in one scan of the range.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from datetime import datetime

from django.db import connection

from history.models import Rollup, Sample
from history.rollup import level_for
from history.storage import utc

_MS = 1, 2, 5, 10, 20, 50, 100, 200, 500
_S = 1, 2, 5, 10, 15, 30, 60, 120, 300, 600, 900, 1800, 3600, 7200, 10800, 21600, 43200, 86400, 172800, 604800
WIDTHS_MS: tuple[int, ...] = (*_MS, *(s * 1000 for s in _S), 2592000000)

_SEGMENT = re.compile(r"^(?:[A-Za-z_][A-Za-z0-9_]*|\d+)$")
_TABLE = Sample._meta.db_table
_ROLLUPS = (
    "SELECT (slot * %s) / %s AS b, min(t_first), min(vmin), max(vmax), sum(vsum), sum(n)"
    f" FROM {Rollup._meta.db_table} WHERE topic = %s AND level_s = %s AND field = %s AND slot >= %s AND slot < %s"
    " GROUP BY 1"
)


class BadField(ValueError):
    pass


def parse_field(path: str) -> list[str]:
    """``pose.position.x`` or ``data.0`` → path segments; anything else is refused."""
    parts = path.split(".") if path else []
    if not parts or not all(_SEGMENT.match(p) for p in parts):
        raise BadField(f"{path!r} is not a dotted field path like current_pleasure or pose.position.x")
    return parts


def bucket_width_ms(span_s: float, max_points: int) -> int:
    return next((width for width in WIDTHS_MS if span_s * 1000 / width <= max_points), WIDTHS_MS[-1])


@dataclass
class Series:
    topic: str
    field: str
    bucket_s: float
    t: list[float]  # epoch seconds of each bucket's first sample
    min: list[float]
    max: list[float]
    mean: list[float]
    count: list[int]


Agg = tuple[float | None, float | None, float | None, float | None, int]  # t_first, min, max, sum, n


def _sql(segments: list[str]) -> tuple[str, list]:
    if connection.vendor == "postgresql":
        # Extract the field once per row (jsonb casts straight to float8); 2-3x faster than #>> per use.
        return (
            "SELECT b, min(t), min(v), max(v), sum(v), count(v) FROM ("
            " SELECT floor(t * 1000 / %s)::bigint AS b, t,"
            " CASE jsonb_typeof(d) WHEN 'number' THEN d::float8"
            " WHEN 'boolean' THEN CASE WHEN d = 'true'::jsonb THEN 1.0 ELSE 0.0 END END AS v"
            " FROM (SELECT extract(epoch FROM received_at)::float8 AS t, data #> %s AS d"
            f" FROM {_TABLE} WHERE topic = %s AND received_at >= %s AND received_at < %s) z) x"
            " WHERE v IS NOT NULL GROUP BY b",
            [segments],
        )
    if connection.vendor == "sqlite":
        path = "$" + "".join(f"[{p}]" if p.isdigit() else f'."{p}"' for p in segments)
        return (
            "SELECT b, min(t), min(v), max(v), sum(v), count(v) FROM ("
            " SELECT CAST((julianday(received_at) - 2440587.5) * 86400000.0 / %s AS INTEGER) AS b,"
            " (julianday(received_at) - 2440587.5) * 86400.0 AS t, json_extract(data, %s) AS v"
            f" FROM {_TABLE} WHERE topic = %s AND received_at >= %s AND received_at < %s"
            " LIMIT -1) x WHERE typeof(v) IN ('integer', 'real') GROUP BY b",
            [path],
        )
    raise NotImplementedError(f"downsampling is not implemented for {connection.vendor}")


def _buckets(sql: str, params: list) -> dict[int, Agg]:
    with connection.cursor() as cursor:
        cursor.execute(sql, params)
        return {int(b): (t, vmin, vmax, vsum, int(n)) for b, t, vmin, vmax, vsum, n in cursor.fetchall()}


def _from_rollups(topic: str, field: str, level: int, width: int, b0: int, b1: int) -> dict[int, Agg] | None:
    """Buckets b0..b1 summed from the rollups; None when ``field`` is not rolled up (read the JSON instead)."""
    if not Rollup.objects.filter(topic=topic, level_s=level, field=field).exists():
        return None
    per_slot = level * 1000
    return _buckets(_ROLLUPS, [per_slot, width, topic, level, field, b0 * width // per_slot,
                               (b1 + 1) * width // per_slot])


def _from_samples(topic: str, field: str, width: int, b0: int, b1: int) -> dict[int, Agg]:
    """Buckets b0..b1 from the JSON."""
    sql, path_params = _sql(parse_field(field))
    adapt = connection.ops.adapt_datetimefield_value
    start, end = adapt(utc(b0 * width / 1000)), adapt(utc((b1 + 1) * width / 1000))
    return _buckets(sql, [width, *path_params, topic, start, end])


def series(*, topic: str, field: str, start: datetime, end: datetime, max_points: int) -> Series:
    """At most ``max_points`` buckets of ``field`` between start and end (bucket edges on the grid)."""
    parse_field(field)
    t0, t1 = start.timestamp(), end.timestamp()
    width = bucket_width_ms(max(t1 - t0, 0.001), max_points)
    b0, b1 = math.floor(t0 * 1000 / width), math.floor(max(t1 * 1000 - 1, t0 * 1000) / width)
    level = level_for(width)
    buckets = _from_rollups(topic, field, level, width, b0, b1) if level else None
    if buckets is None:
        buckets = _from_samples(topic, field, width, b0, b1)
    kept = [buckets[i] for i in sorted(buckets) if b0 <= i <= b1 and buckets[i][4]]  # n > 0: all of it is set
    t, vmin, vmax, vsum, n = map(list, zip(*kept, strict=True)) if kept else ([], [], [], [], [])
    return Series(topic=topic, field=field, bucket_s=width / 1000, t=t, min=vmin, max=vmax,
                  mean=[total / count for total, count in zip(vsum, n, strict=True)], count=n)
