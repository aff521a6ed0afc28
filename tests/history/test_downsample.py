import math
import time

import pytest

from history.downsample import BadField, bucket_width_ms, series
from history.models import SeriesBucket
from history.storage import utc, write_rows

TOPIC = "/bench/downsample"


def _write(values: list[tuple[float, object]], topic: str = TOPIC) -> None:
    import json

    write_rows([(topic, "std_msgs/Float32", t, json.dumps({"data": v, "nested": {"x": v}})) for t, v in values])


def test_it_keeps_spikes_and_dips_when_zoomed_out(db):
    t0 = time.time() - 7200
    values = [(t0 + i * 0.5, math.sin(i / 50)) for i in range(10_000)]
    values[4321] = (values[4321][0], 42.0)
    values[777] = (values[777][0], -17.5)
    _write(values)

    s = series(topic=TOPIC, field="data", start=utc(t0), end=utc(t0 + 5000), max_points=200)

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


def test_it_sees_rows_written_into_an_already_cached_range(db):
    t0 = time.time() - 3600
    _write([(t0 + i, 1.0) for i in range(100)])
    first = series(topic=TOPIC, field="data", start=utc(t0), end=utc(t0 + 100), max_points=10)
    assert SeriesBucket.objects.filter(topic=TOPIC).exists()
    assert max(first.max) == 1.0

    _write([(t0 + 50.5, 99.0)])
    second = series(topic=TOPIC, field="data", start=utc(t0), end=utc(t0 + 100), max_points=10)

    assert max(second.max) == 99.0
    assert sum(second.count) == 101


def test_it_never_caches_the_open_tail(db):
    now = time.time()
    _write([(now - 1, 1.0)])
    series(topic=TOPIC, field="data", start=utc(now - 5), end=utc(now), max_points=10)
    _write([(now - 0.5, 5.0)])

    s = series(topic=TOPIC, field="data", start=utc(now - 5), end=utc(now), max_points=10)

    assert max(s.max) == 5.0


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
