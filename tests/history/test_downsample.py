import json
import math
import random
import time

import pytest

from history.downsample import BadField, bucket_width_ms, series
from history.models import Rollup, Sample
from history.rollup import MAX_LEAVES, aggregate
from history.storage import utc, write_rows

pytestmark = pytest.mark.postgres  # the history store: its writes, queries and rollups differ by engine

TOPIC = "/bench/downsample"
# "data" is rolled up at write time; "wide.0" sits in a 12-item array, which the rollups leave
# out, so it is always read from the JSON.
ROLLED_UP, FROM_JSON = "data", "wide.0"
BOTH_PATHS = pytest.mark.parametrize("field", [ROLLED_UP, FROM_JSON])


def _write(values: list[tuple[float, object]], topic: str = TOPIC) -> None:
    write_rows([(topic, "std_msgs/Float32", t, json.dumps({"data": v, "nested": {"x": v}, "wide": [v] * 12}))
                for t, v in values])


@BOTH_PATHS
def test_it_keeps_spikes_and_dips_when_zoomed_out(db, field):
    t0 = time.time() - 7200
    values = [(t0 + i * 0.5, math.sin(i / 50)) for i in range(10_000)]
    values[4321] = (values[4321][0], 42.0)
    values[777] = (values[777][0], -17.5)
    _write(values)

    s = series(topic=TOPIC, field=field, start=utc(t0), end=utc(t0 + 5000), max_points=200)

    assert 0 < len(s.t) <= 200
    assert max(s.max) == 42.0
    assert min(s.min) == -17.5
    assert sum(s.count) == 10_000
    assert s.t == sorted(s.t)


def test_it_returns_raw_values_when_they_fit(db):
    t0 = time.time() - 3600
    _write([(t0 + i, float(i)) for i in range(50)])

    s = series(topic=TOPIC, field="nested.x", start=utc(t0), end=utc(t0 + 50), max_points=2000)

    assert s.count == [1] * 50
    assert s.min == s.max == s.mean == [float(i) for i in range(50)]
    assert s.t[0] == pytest.approx(t0, abs=0.01)


@BOTH_PATHS
def test_it_sees_rows_written_into_an_already_served_range(db, field):
    t0 = time.time() - 3600
    _write([(t0 + i, 1.0) for i in range(100)])
    first = series(topic=TOPIC, field=field, start=utc(t0), end=utc(t0 + 100), max_points=10)
    assert max(first.max) == 1.0

    _write([(t0 + 50.5, 99.0)])
    second = series(topic=TOPIC, field=field, start=utc(t0), end=utc(t0 + 100), max_points=10)

    assert max(second.max) == 99.0
    assert sum(second.count) == 101


@BOTH_PATHS
def test_it_shows_rows_written_into_the_open_tail(db, field):
    now = time.time()
    _write([(now - 1, 1.0)])
    series(topic=TOPIC, field=field, start=utc(now - 5), end=utc(now), max_points=2)
    _write([(now - 0.5, 5.0)])

    s = series(topic=TOPIC, field=field, start=utc(now - 5), end=utc(now), max_points=2)

    assert max(s.max) == 5.0


def test_it_serves_buckets_of_a_second_or_more_from_the_rollups_not_the_json(db):
    t0 = time.time() - 600
    _write([(t0 + i, float(i)) for i in range(120)])
    Sample.objects.filter(topic=TOPIC).update(data={"data": -1.0})

    wide = series(topic=TOPIC, field="data", start=utc(t0), end=utc(t0 + 120), max_points=60)
    narrow = series(topic=TOPIC, field="data", start=utc(t0), end=utc(t0 + 120), max_points=1000)

    assert wide.bucket_s == 2.0 and max(wide.max) == 119.0 and sum(wide.count) == 120
    assert narrow.bucket_s < 1 and set(narrow.max) == {-1.0}


def test_it_gives_the_same_series_from_the_rollups_as_from_the_json(db):
    rnd = random.Random(3)
    t0 = time.time() - 3 * 86400
    t, values = t0, []
    for _ in range(4000):
        t += rnd.choice([0.01, 0.3, 1.7, 45.0, 700.0])
        values.append((t, rnd.choice([rnd.uniform(-5, 5), rnd.randint(-3, 3), True, False, "text"])))
    _write(values)
    spans = [(t0, t + 1, 300), (t0, t + 1, 2000), (t0 + 3600, t0 + 7200, 100), (t0 + 100, t0 + 40_000, 17),
             (t0, t0 + 3000, 1000)]

    from_rollups = [vars(series(topic=TOPIC, field="data", start=utc(a), end=utc(b), max_points=n))
                    for a, b, n in spans]
    Rollup.objects.filter(topic=TOPIC).delete()  # nothing rolled up: the same requests read the JSON
    from_json = [vars(series(topic=TOPIC, field="data", start=utc(a), end=utc(b), max_points=n))
                 for a, b, n in spans]

    for rolled, parsed in zip(from_rollups, from_json, strict=True):
        assert rolled["bucket_s"] >= 1 and rolled["count"] == parsed["count"] and sum(rolled["count"]) > 0
        assert rolled["t"] == pytest.approx(parsed["t"], abs=1e-3)  # SQLite's julianday() is good to ~50 µs
        for key in ("min", "max", "mean"):
            assert rolled[key] == pytest.approx(parsed[key], abs=1e-9), key


def test_it_rolls_up_a_bounded_number_of_leaves_per_message_and_skips_long_arrays():
    msg = {f"f{i:02d}": i for i in range(MAX_LEAVES + 8)} | {"ranges": [1.0] * 100, "ok": True, "s": "x"}

    fields = {field for (_, _, field, _) in aggregate([(TOPIC, 10.5, msg)], levels=(1,))}

    assert len(fields) == MAX_LEAVES
    assert "f00" in fields and "ok" not in fields and not any(f.startswith("ranges") for f in fields)


def test_it_skips_text_and_counts_booleans_as_numbers(db):
    t0 = time.time() - 600
    _write([(t0, "hello"), (t0 + 1, True), (t0 + 2, 3.5), (t0 + 3, False)])

    s = series(topic=TOPIC, field="data", start=utc(t0), end=utc(t0 + 4), max_points=100)

    assert s.max == [1.0, 3.5, 0.0]


def test_it_refuses_a_field_that_is_not_a_dotted_path(db):
    with pytest.raises(BadField):
        series(topic=TOPIC, field="data') OR 1=1 --", start=utc(0), end=utc(1), max_points=10)


def test_it_picks_a_bucket_width_that_fits_the_point_budget():
    assert bucket_width_ms(86400, 2000) == 60_000
    assert bucket_width_ms(1, 2000) == 1
    assert 86400 * 7 * 1000 / bucket_width_ms(86400 * 7, 2000) <= 2000


def test_it_backfills_the_rollups_of_samples_stored_before_they_existed(db, monkeypatch):
    from importlib import import_module

    from django.apps import apps

    migration = import_module("history.migrations.0002_rollup")
    monkeypatch.setattr(migration, "BACKFILL_CHUNK", 7)  # many batches, each cut between minutes
    t0 = time.time() - 7200
    _write([(t0 + i * 3.3, float(i % 17)) for i in range(600)])
    _write([(t0 + i, float(i)) for i in range(30)], topic="/other")
    columns = ("topic", "level_s", "field", "slot", "t_first", "vmin", "vmax", "vsum", "n")
    written = sorted(Rollup.objects.values_list(*columns))
    Rollup.objects.all().delete()

    migration.backfill(apps, None)

    backfilled = sorted(Rollup.objects.values_list(*columns))
    assert len(backfilled) == len(written) > 600
    for got, want in zip(backfilled, written, strict=True):
        assert got[:4] == want[:4] and got[8] == want[8]
        assert got[4:8] == pytest.approx(want[4:8], abs=1e-3)  # stored times are whole microseconds
