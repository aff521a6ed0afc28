"""Time to serve a 2,000-point series from 1,000,000 stored samples, SQLite and PostgreSQL.

One topic gets 1,000,000 battery samples at 10 Hz ending now (about 28 hours), written the
way the recorder writes them (``encode`` then ``write_rows``: rows with COPY on PostgreSQL,
executemany on SQLite, and their per-second and per-minute rollups). The series selector
the API's ``/api/history/samples/`` calls then asks for the whole span at most 2,000 points:
one-minute buckets, summed from the minute rollups. ``cold_ms`` is the first request,
``p50_ms``/``p99_ms`` 20 more (the range ending at the moment of the request, as a live
page asks). ``zoomed_cold_ms``: the last 10 minutes at 2,000 points, half-second buckets,
which no rollup tiles, so it reads the JSON of its 6,000 rows (the fallback path).

Run: .venv/bin/python bench/history_query.py
"""

from __future__ import annotations

import json
import random
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _history_db import run_per_backend, setup_child

ROWS = 1_000_000
RATE_HZ = 10
MAX_POINTS = 2000
RUNS = 20


def child() -> None:
    setup_child()
    from django.db import connection

    from history.downsample import series
    from history.models import Sample
    from history.storage import encode, utc, write_rows

    topic, now = "/RosAria/battery_state_of_charge", time.time()
    t0 = now - ROWS / RATE_HZ
    rnd = random.Random(7)
    started = time.perf_counter()
    batch = []
    for i in range(ROWS):
        batch.append((topic, "std_msgs/Float32", {"data": round(rnd.random(), 4)}, t0 + i / RATE_HZ))
        if len(batch) == 100_000:
            write_rows(encode(batch, {}, default_max=1024)[0])
            batch = []
    write_rows(encode(batch, {}, default_max=1024)[0])
    load_s = time.perf_counter() - started
    if connection.vendor == "postgresql":
        # A live table is vacuumed by autovacuum as rows trickle in; a 1M-row bulk load is not yet,
        # and the first scan would also pay for setting every row's hint bits.
        with connection.cursor() as cursor:
            cursor.execute(f"VACUUM ANALYZE {Sample._meta.db_table}")
    assert Sample.objects.filter(topic=topic).count() == ROWS

    def once(span_s: float | None = None) -> tuple[float, int]:
        end = time.time()
        begin = time.perf_counter()
        s = series(topic=topic, field="data", start=utc(end - span_s if span_s else t0), end=utc(end),
                   max_points=MAX_POINTS)
        return (time.perf_counter() - begin) * 1000, len(s.t)

    cold_ms, points = once()
    warm = sorted(once()[0] for _ in range(RUNS))
    zoomed_ms, _ = once(600)
    print(json.dumps({"load_s": load_s, "cold_ms": cold_ms, "points": points, "zoomed_cold_ms": zoomed_ms,
                      "p50_ms": statistics.median(warm), "p99_ms": warm[-1]}))


def main() -> None:
    results = run_per_backend(__file__)
    print(f"stored_samples: {ROWS}")
    for name, r in results.items():
        print(f"{name}_points: {r['points']}")
        print(f"{name}_cold_ms: {r['cold_ms']:.1f}")
        print(f"{name}_p50_ms: {r['p50_ms']:.1f}")
        print(f"{name}_p99_ms: {r['p99_ms']:.1f}")
        print(f"{name}_zoomed_cold_ms: {r['zoomed_cold_ms']:.1f}")
        print(f"{name}_load_1M_rows_s: {r['load_s']:.1f}")


if __name__ == "__main__":
    child() if "--child" in sys.argv else main()
