"""Recording through a real Celery worker (solo pool, in a thread) with Redis as the broker."""

import time

from django.conf import settings
from django.db import OperationalError

from history.models import Mode, Sample
from history.policies import load_policies, policy_upsert
from history.recorder import Recorder
from history.sampling import latest_key
from history.storage import utc, write_rows
from history.tasks import celery_writer_for
from robot.live.state import get_store
from tests.helpers import wait_until

from .conftest import BURST_TOPIC, BURST_TYPE

PERIODIC = "/history_test/celery_periodic"


def _count(topic: str) -> int:
    # The test database is SQLite in shared-cache memory mode, where a read while the worker
    # writes fails at once with "table is locked" instead of waiting; just ask again.
    try:
        return Sample.objects.filter(topic=topic).count()
    except OperationalError:
        return -1


def test_it_samples_periodic_topics_in_the_worker_from_the_latest_state_store(celery_app, celery_worker_thread):
    policy_upsert(topic=PERIODIC, msg_type="std_msgs/Float32", mode=Mode.PERIODIC, interval_s=1)
    t = time.time()
    get_store().put(latest_key(PERIODIC), {"key": latest_key(PERIODIC), "topic": PERIODIC,
                                           "msg_type": "std_msgs/Float32", "msg": {"data": 0.5}, "t": t})

    celery_app.send_task("history.sample")

    wait_until(lambda: _count(PERIODIC) == 1, timeout=15, what="the worker's sample")
    sample = Sample.objects.get(topic=PERIODIC)
    assert sample.data == {"data": 0.5}
    assert abs(sample.received_at.timestamp() - t) < 0.001


def test_it_writes_every_message_batches_in_the_worker(celery_app, celery_worker_thread):
    policy_upsert(topic=BURST_TOPIC, msg_type=BURST_TYPE, mode=Mode.EVERY)
    rec = Recorder(writer=celery_writer_for(celery_app), batch_rows=250)
    rec.apply(load_policies())
    for i in range(1000):
        rec.offer(BURST_TOPIC, BURST_TYPE, {"data": i}, time.time())

    rec.flush_sync(rec.take())

    wait_until(lambda: _count(BURST_TOPIC) == 1000, timeout=20, what="1000 rows")
    assert sorted(Sample.objects.filter(topic=BURST_TOPIC).values_list("data__data", flat=True)) == list(range(1000))


def test_it_prunes_in_the_worker(celery_app, celery_worker_thread):
    policy_upsert(topic=PERIODIC, msg_type="std_msgs/Float32", mode=Mode.PERIODIC, retention_s=60)
    now = time.time()
    write_rows([(PERIODIC, "std_msgs/Float32", now - 120, '{"data": 1}'), (PERIODIC, "std_msgs/Float32", now, "{}")])

    celery_app.send_task("history.prune")

    wait_until(lambda: _count(PERIODIC) == 1, timeout=15, what="the old row pruned")
    assert Sample.objects.get(topic=PERIODIC).received_at >= utc(now - 1)


def test_it_schedules_sampling_and_pruning_with_expiry_under_the_period(celery_app):
    schedule = settings.CELERY_BEAT_SCHEDULE
    for entry in (schedule["history-sample"], schedule["history-prune"]):
        assert entry["task"] in celery_app.tasks
        assert 0 < entry["options"]["expires"] < entry["schedule"]
