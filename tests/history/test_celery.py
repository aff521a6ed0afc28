"""History's beat work (pruning) in a real Celery worker (solo pool, in a thread) with Redis as the broker."""

import time

import pytest
from django.conf import settings
from django.db import OperationalError

from history.models import Mode, Sample
from history.policies import policy_upsert
from history.storage import utc, write_rows
from tests.helpers import wait_until

pytestmark = pytest.mark.postgres  # the history store, written by a real worker

PERIODIC = "/history_test/celery_periodic"


def _count(topic: str) -> int:
    # The test database is SQLite in shared-cache memory mode, where a read while the worker
    # writes fails at once with "table is locked" instead of waiting; just ask again.
    try:
        return Sample.objects.filter(topic=topic).count()
    except OperationalError:
        return -1


def test_it_prunes_in_the_worker(celery_app, celery_worker_thread):
    policy_upsert(topic=PERIODIC, msg_type="std_msgs/Float32", mode=Mode.PERIODIC, retention_s=60)
    now = time.time()
    write_rows([(PERIODIC, "std_msgs/Float32", now - 120, '{"data": 1}'), (PERIODIC, "std_msgs/Float32", now, "{}")])

    celery_app.send_task("history.prune")

    wait_until(lambda: _count(PERIODIC) == 1, timeout=15, what="the old row pruned")
    assert Sample.objects.get(topic=PERIODIC).received_at >= utc(now - 1)


def test_it_schedules_pruning_with_expiry_under_the_period(celery_app):
    entry = settings.CELERY_BEAT_SCHEDULE["history-prune"]
    assert entry["task"] in celery_app.tasks
    assert 0 < entry["options"]["expires"] < entry["schedule"]
