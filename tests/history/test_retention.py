import time

import pytest
from django.test import Client

from history.downsample import series
from history.models import Mode, Rollup, Sample
from history.policies import policy_upsert
from history.retention import prune_expired
from history.storage import utc, write_rows

pytestmark = pytest.mark.postgres  # the history store: its writes, queries and rollups differ by engine


def _write(topic: str, values: list[tuple[float, float]]) -> None:
    write_rows([(topic, "std_msgs/Float32", t, f'{{"data": {v}, "wide": {[v] * 12}}}') for t, v in values])


def test_it_deletes_samples_older_than_the_topics_retention(db):
    now = time.time()
    policy_upsert(topic="/short", msg_type="std_msgs/Int32", mode=Mode.EVERY, retention_s=3600)
    policy_upsert(topic="/forever", msg_type="std_msgs/Int32", mode=Mode.EVERY)
    write_rows([(topic, "std_msgs/Int32", now - age, f'{{"data": {age}}}')
                for topic in ("/short", "/forever") for age in (7200, 5000, 100)])

    assert prune_expired(now=now) == 2

    assert list(Sample.objects.filter(topic="/short").values_list("data__data", flat=True)) == [100]
    assert Sample.objects.filter(topic="/forever").count() == 3
    assert Rollup.objects.filter(topic="/short", level_s=1).count() == 1
    assert Rollup.objects.filter(topic="/forever", level_s=1).count() == 3


@pytest.mark.parametrize("field", ["data", "wide.0"])
def test_it_forgets_what_it_derived_from_pruned_samples(db, field):
    now = time.time()
    policy_upsert(topic="/short", msg_type="std_msgs/Int32", mode=Mode.EVERY, retention_s=3600)
    _write("/short", [(now - 7200 + i, i) for i in range(100)])
    before = series(topic="/short", field=field, start=utc(now - 7300), end=utc(now - 7000), max_points=10)
    assert sum(before.count) == 100

    prune_expired(now=now)

    assert not Rollup.objects.filter(topic="/short").exists()
    again = series(topic="/short", field=field, start=utc(now - 7300), end=utc(now - 7000), max_points=10)
    assert again.count == []


def test_it_keeps_the_rollups_of_the_samples_kept_beside_the_cutoff(db):
    base = 1_800_000_000.0  # on a whole minute
    policy_upsert(topic="/short", msg_type="std_msgs/Float32", mode=Mode.EVERY, retention_s=100)
    _write("/short", [(base + i * 0.25, float(i)) for i in range(480)])  # 0..119.75 s, two minutes

    prune_expired(now=base + 30.4 + 100)  # the cutoff falls inside a second and inside the first minute

    kept = list(Sample.objects.filter(topic="/short").values_list("data__data", flat=True))
    assert min(kept) == 122  # 30.5 s
    for points in (2, 120):  # one-minute buckets (minute rollups), one-second buckets (second rollups)
        s = series(topic="/short", field="data", start=utc(base), end=utc(base + 120), max_points=points)
        assert sum(s.count) == len(kept)
        assert min(s.min) == 122.0 and s.t[0] == pytest.approx(base + 30.5, abs=1e-3)


def test_it_rebuilds_the_rollups_when_an_admin_deletes_samples(db, admin_user):
    t0 = time.time() - 3600
    _write("/admin", [(t0 + i, float(i)) for i in range(60)])
    spike = Sample.objects.get(topic="/admin", data__data=30)
    Sample.objects.filter(pk=spike.pk).update(data={"data": 500.0})
    write_rows([("/admin", "std_msgs/Float32", t0 + 30.5, '{"data": 1000.0}')])
    doomed = list(Sample.objects.filter(data__data__gte=500).values_list("pk", flat=True))
    client = Client()
    client.force_login(admin_user)

    res = client.post("/admin/history/sample/", {"action": "delete_selected", "_selected_action": doomed,
                                                 "post": "yes"})

    assert res.status_code == 302
    assert Sample.objects.filter(topic="/admin").count() == 59
    s = series(topic="/admin", field="data", start=utc(t0), end=utc(t0 + 60), max_points=30)
    assert s.bucket_s == 2.0
    assert max(s.max) == 59.0 and sum(s.count) == 59
