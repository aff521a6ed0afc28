"""The recorder in the embedded wiring: the link on the test's loop, connected to the simulator."""

import asyncio
import logging
import time

import pytest
from asgiref.sync import sync_to_async

from history.models import Mode, Sample, TopicPolicy
from history.policies import policy_upsert
from history.recorder import Recorder
from robot import interface as ri
from tests.helpers import async_wait_until

from .conftest import BURST_TOPIC, BURST_TYPE

# The history store: its writes, queries and rollups differ by engine.
pytestmark = [pytest.mark.postgres, pytest.mark.django_db(transaction=True)]

count = sync_to_async(lambda topic: Sample.objects.filter(topic=topic).count())


async def _wait_count(topic: str, n: int, timeout: float = 10) -> None:
    deadline = time.monotonic() + timeout
    while (stored := await count(topic)) < n:
        assert time.monotonic() < deadline, f"only {stored} of {n} samples of {topic} after {timeout} s"
        await asyncio.sleep(0.05)


def _burst(sim, n: int) -> None:
    sim.call(lambda: [sim.robot.publish_external(BURST_TOPIC, {"data": i}) for i in range(n)])


async def _subscribed(sim, topic: str) -> None:
    await async_wait_until(lambda: sim.subscription_count(topic) > 0, timeout=10, what=f"a subscription to {topic}")


async def test_it_stores_every_message_of_a_counted_burst(recording, sim, link):
    await sync_to_async(policy_upsert)(topic=BURST_TOPIC, msg_type=BURST_TYPE, mode=Mode.EVERY)
    await _subscribed(sim, BURST_TOPIC)

    _burst(sim, 2000)

    # The recorder's own count takes in the other topics it keeps, so the burst is counted where it is stored.
    await _wait_count(BURST_TOPIC, 2000, timeout=20)
    assert await count(BURST_TOPIC) == 2000
    values = await sync_to_async(lambda: sorted(
        Sample.objects.filter(topic=BURST_TOPIC).values_list("data__data", flat=True)))()
    assert values == list(range(2000))
    assert recording.dropped == 0


async def test_it_follows_policy_changes_without_a_restart(recording, sim, link):
    await _subscribed(sim, ri.topic("battery_soc").name)
    assert sim.subscription_count(BURST_TOPIC) == 0

    await sync_to_async(policy_upsert)(topic=BURST_TOPIC, msg_type=BURST_TYPE, mode=Mode.EVERY)
    await _subscribed(sim, BURST_TOPIC)
    _burst(sim, 10)
    await _wait_count(BURST_TOPIC, 10)

    await sync_to_async(policy_upsert)(topic=BURST_TOPIC, mode=Mode.OFF)
    await async_wait_until(lambda: sim.subscription_count(BURST_TOPIC) == 0, timeout=10, what="unsubscribed")
    assert await count(BURST_TOPIC) == 10


async def test_it_samples_periodic_topics_as_they_arrive(recording, sim, link):
    battery = ri.topic("battery_soc")  # the simulator publishes it once a second
    await sync_to_async(policy_upsert)(topic=battery.name, msg_type=battery.type, mode=Mode.PERIODIC, interval_s=0.5)

    await _wait_count(battery.name, 2)

    samples = await sync_to_async(lambda: list(Sample.objects.filter(topic=battery.name).order_by("received_at")))()
    assert samples[0].msg_type == battery.type
    assert 0 <= samples[0].data["data"] <= 1
    assert (samples[1].received_at - samples[0].received_at).total_seconds() >= 0.4
    assert time.time() - samples[-1].received_at.timestamp() < 10


def test_it_leaves_oversize_messages_out_with_a_warning(db, caplog):
    TopicPolicy.objects.create(topic=BURST_TOPIC, msg_type=BURST_TYPE, mode=Mode.EVERY, max_message_bytes=100)
    rec = Recorder(flush_s=1, batch_rows=10, buffer_rows=10)
    from history.policies import load_policies

    rec.apply(load_policies())
    rec.offer(BURST_TOPIC, BURST_TYPE, {"data": "x" * 500}, time.time())
    rec.offer(BURST_TOPIC, BURST_TYPE, {"data": "ok"}, time.time())

    with caplog.at_level(logging.WARNING, logger="history"):
        assert rec.flush_sync(rec.take()) == 1

    assert rec.oversize == 1
    assert f"not storing a 511-byte message on {BURST_TOPIC} (limit 100 bytes)" in caplog.text
    assert list(Sample.objects.values_list("data", flat=True)) == [{"data": "ok"}]


def test_it_counts_and_logs_messages_dropped_when_the_buffer_is_full(db, caplog):
    rec = Recorder(flush_s=1, batch_rows=100, buffer_rows=3)
    rec.every = frozenset({BURST_TOPIC})

    with caplog.at_level(logging.ERROR, logger="history"):
        for i in range(5):
            rec.offer(BURST_TOPIC, BURST_TYPE, {"data": i}, time.time())

    assert len(rec.take()) == 3
    assert rec.dropped == 2
    assert "buffer full" in caplog.text


def test_it_keeps_unwritten_rows_for_the_next_flush_when_the_database_fails(db):
    calls = []

    def flaky(rows):
        calls.append(len(rows))
        if len(calls) == 1:
            raise RuntimeError("database went away")
        return len(rows)

    rec = Recorder(writer=flaky, flush_s=1, batch_rows=100, buffer_rows=100)
    rec.every = frozenset({BURST_TOPIC})
    rec.offer(BURST_TOPIC, BURST_TYPE, {"data": 1}, time.time())
    with pytest.raises(RuntimeError):
        rec.flush_sync(rec.take())

    rec.offer(BURST_TOPIC, BURST_TYPE, {"data": 2}, time.time())
    rec.flush_sync(rec.take())

    assert calls == [1, 2]
    assert rec.stored == 2
