import time

from history.downsample import series
from history.models import Mode, Sample, SeriesBucket
from history.policies import policy_upsert
from history.retention import prune_expired
from history.storage import utc, write_rows


def test_it_deletes_samples_older_than_the_topics_retention(db):
    now = time.time()
    policy_upsert(topic="/short", msg_type="std_msgs/Int32", mode=Mode.EVERY, retention_s=3600)
    policy_upsert(topic="/forever", msg_type="std_msgs/Int32", mode=Mode.EVERY)
    write_rows([(topic, "std_msgs/Int32", now - age, f'{{"data": {age}}}')
                for topic in ("/short", "/forever") for age in (7200, 5000, 100)])

    assert prune_expired(now=now) == 2

    assert list(Sample.objects.filter(topic="/short").values_list("data__data", flat=True)) == [100]
    assert Sample.objects.filter(topic="/forever").count() == 3


def test_it_forgets_cached_buckets_of_pruned_samples(db):
    now = time.time()
    policy_upsert(topic="/short", msg_type="std_msgs/Int32", mode=Mode.EVERY, retention_s=3600)
    write_rows([("/short", "std_msgs/Int32", now - 7200 + i, f'{{"data": {i}}}') for i in range(100)])
    series(topic="/short", field="data", start=utc(now - 7300), end=utc(now - 7000), max_points=10)
    assert SeriesBucket.objects.filter(topic="/short", n__gt=0).exists()

    prune_expired(now=now)

    assert not SeriesBucket.objects.filter(topic="/short", n__gt=0).exists()
    again = series(topic="/short", field="data", start=utc(now - 7300), end=utc(now - 7000), max_points=10)
    assert again.count == []
