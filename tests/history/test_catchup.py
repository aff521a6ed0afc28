"""A stopped sampler (a Celery worker outage) stores every period it missed when it runs again."""

import time

import pytest
from asgiref.sync import async_to_sync
from django.test import override_settings

from history.models import Mode, Sample
from history.policies import load_policies, policy_upsert
from history.recorder import Recorder
from history.sampling import sample_periodic
from robot.live.state import get_store
from tests.helpers import wait_until

PERIODIC = "/history_test/catchup"
TYPE = "std_msgs/Float32"


def _record(rec: Recorder, start: float, seconds: float, hz: float = 4) -> None:
    """Messages at ``hz`` for ``seconds`` of robot time, handed to the store as the link's recorder does."""
    for i in range(int(seconds * hz)):
        rec.offer(PERIODIC, TYPE, {"data": float(i)}, start + i / hz)
        if i % 5 == 4:
            async_to_sync(rec.publish_latest)(get_store())
    async_to_sync(rec.publish_latest)(get_store())


def _sampled_times() -> list[float]:
    return sorted(s.received_at.timestamp() for s in Sample.objects.filter(topic=PERIODIC))


def test_a_sampler_that_was_down_stores_one_sample_per_missed_interval(db):
    policy_upsert(topic=PERIODIC, msg_type=TYPE, mode=Mode.PERIODIC, interval_s=1)
    rec = Recorder()
    rec.apply(load_policies())
    start = time.time() - 30

    _record(rec, start, 20)  # twenty intervals with no sampler running
    stored = sample_periodic()

    assert stored == 20
    times = _sampled_times()
    assert [round(t - start, 1) for t in times] == [float(i) for i in range(20)]
    assert sample_periodic() == 0  # nothing stored twice


def test_the_backlog_is_bounded_and_keeps_the_newest(db):
    policy_upsert(topic=PERIODIC, msg_type=TYPE, mode=Mode.PERIODIC, interval_s=1)
    rec = Recorder()
    rec.apply(load_policies())
    start = time.time() - 30

    with override_settings(HISTORY_BACKLOG_SAMPLES=5):
        _record(rec, start, 12)
    assert sample_periodic() == 5
    assert [round(t - start, 1) for t in _sampled_times()] == [7.0, 8.0, 9.0, 10.0, 11.0]


def test_a_real_worker_back_from_an_outage_catches_up(celery_app, transactional_db):
    from celery.contrib.testing.worker import start_worker

    policy_upsert(topic=PERIODIC, msg_type=TYPE, mode=Mode.PERIODIC, interval_s=1)
    rec = Recorder()
    rec.apply(load_policies())
    start = time.time() - 30
    _record(rec, start, 10)  # the worker is down: beat's sample tasks expire unconsumed

    with start_worker(celery_app, pool="solo", perform_ping_check=False, shutdown_timeout=10):
        celery_app.send_task("history.sample")
        wait_until(lambda: Sample.objects.filter(topic=PERIODIC).count() == 10, timeout=20,
                   what="ten samples after the outage")


def test_a_recorder_taking_over_counts_the_messages_missed_since_the_previous_one(db):
    from history.recorder import WATERMARK_KEY

    policy_upsert(topic=PERIODIC, msg_type=TYPE, mode=Mode.EVERY)
    store = get_store()
    start = time.time() - 30
    first = Recorder()
    first.apply(load_policies())
    for i in range(40):  # 2 s at 20 Hz, written
        first.offer(PERIODIC, TYPE, {"data": i}, start + i / 20)
    first.flush_sync(first.take())
    async_to_sync(first.publish_latest)(store)
    assert store.get_all()[WATERMARK_KEY]["topics"][PERIODIC][1] == pytest.approx(20)
    for i in range(40, 45):  # taken but never written: the process dies before its next flush
        first.offer(PERIODIC, TYPE, {"data": i}, start + i / 20)

    second = Recorder()
    second.apply(load_policies())
    async_to_sync(second.resume_after)(store)
    second.offer(PERIODIC, TYPE, {"data": 50}, start + 50 / 20)  # 40..49 never reached the database

    assert second.gap_lost == {PERIODIC: 10}


def test_numbered_messages_are_counted_exactly_and_the_count_adds_up_across_recorders(db):
    from history.recorder import WATERMARK_KEY, losses

    policy_upsert(topic=PERIODIC, msg_type="nav_msgs/Odometry", mode=Mode.EVERY)
    store = get_store()
    store.put(WATERMARK_KEY, {})
    start = time.time() - 30

    def recorder(seqs: list[int], at: float) -> Recorder:
        rec = Recorder(writer=lambda rows: len(rows))
        rec.apply(load_policies())
        async_to_sync(rec.resume_after)(store)
        for n, seq in enumerate(seqs):  # irregular timing: the numbers, not the clock, tell the gap
            rec.offer(PERIODIC, "nav_msgs/Odometry", {"header": {"seq": seq}}, at + n * 0.3)
        rec.flush_sync(rec.take())
        async_to_sync(rec.publish_latest)(store)
        return rec

    recorder([1, 2, 3], start)
    assert recorder([10, 11], start + 1).gap_lost == {PERIODIC: 6}
    assert recorder([12, 13], start + 9).gap_lost == {PERIODIC: 0}
    assert losses(store.get_all()[WATERMARK_KEY]) == {PERIODIC: 6}
    # The robot restarted and numbers from 1 again: unknown, not counted (and not negative).
    assert recorder([1, 2], start + 20).gap_lost == {}
    assert losses(store.get_all()[WATERMARK_KEY]) == {PERIODIC: 6}
