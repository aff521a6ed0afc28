"""Periodic topics are sampled where the link hears them: a Celery worker outage loses no period;
a recorder taking over counts the messages that fell between it and the previous one."""

import time

import pytest
from asgiref.sync import async_to_sync

from history.models import Mode, Sample
from history.policies import load_policies, policy_upsert
from history.recorder import Recorder
from robot.live.state import get_store

pytestmark = pytest.mark.postgres  # the history store: its writes, queries and rollups differ by engine

PERIODIC = "/history_test/catchup"
TYPE = "std_msgs/Float32"


def _sampled_times() -> list[float]:
    return sorted(s.received_at.timestamp() for s in Sample.objects.filter(topic=PERIODIC))


def test_periodic_topics_keep_one_sample_per_interval_with_no_worker_running(db):
    policy_upsert(topic=PERIODIC, msg_type=TYPE, mode=Mode.PERIODIC, interval_s=1)
    rec = Recorder()
    rec.apply(load_policies())
    start = time.time() - 30

    for i in range(20 * 4):  # twenty intervals at 4 Hz, no Celery worker anywhere
        rec.offer(PERIODIC, TYPE, {"data": float(i)}, start + i / 4)
        if i % 5 == 4:
            rec.flush_sync(rec.take())
    rec.flush_sync(rec.take())

    assert [round(t - start, 1) for t in _sampled_times()] == [float(i) for i in range(20)]
    rec.offer(PERIODIC, TYPE, {"data": 0.0}, start + 19.75)  # the same moment again: nothing stored twice
    assert rec.flush_sync(rec.take()) == 0


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
    async_to_sync(first.publish_watermark)(store)
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
        async_to_sync(rec.publish_watermark)(store)
        return rec

    recorder([1, 2, 3], start)
    assert recorder([10, 11], start + 1).gap_lost == {PERIODIC: 6}
    assert recorder([12, 13], start + 9).gap_lost == {PERIODIC: 0}
    assert losses(store.get_all()[WATERMARK_KEY]) == {PERIODIC: 6}
    # The robot restarted and numbers from 1 again: unknown, not counted (and not negative).
    assert recorder([1, 2], start + 20).gap_lost == {}
    assert losses(store.get_all()[WATERMARK_KEY]) == {PERIODIC: 6}


def test_a_recorder_taking_over_goes_on_from_the_last_sample_stored(transactional_db):
    import types

    policy_upsert(topic=PERIODIC, msg_type=TYPE, mode=Mode.PERIODIC, interval_s=10)
    link = types.SimpleNamespace(subscriptions=types.SimpleNamespace(subscribe=lambda *a, **k: None,
                                                               unsubscribe=lambda *a, **k: None))
    start = time.time() - 60
    first = Recorder()
    async_to_sync(first.reload)(link)
    first.offer(PERIODIC, TYPE, {"data": 1.0}, start)
    first.flush_sync(first.take())

    second = Recorder()  # a failover or a restart, 4 s into the 10 s interval
    async_to_sync(second.reload)(link)
    second.offer(PERIODIC, TYPE, {"data": 2.0}, start + 4)
    second.offer(PERIODIC, TYPE, {"data": 3.0}, start + 10)
    second.flush_sync(second.take())

    assert [round(t - start, 1) for t in _sampled_times()] == [0.0, 10.0]
