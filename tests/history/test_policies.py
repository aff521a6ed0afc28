import time

import pytest

from history.models import Mode, RecordingSettings, Sample, TopicPolicy
from history.policies import default_interval_set, load_policies, policies_add_discovered, policy_upsert
from history.recorder import Recorder

pytestmark = pytest.mark.postgres  # the history store: its writes, queries and rollups differ by engine

TOPIC = "/history_test/periodic"


def _stored(rec: Recorder, t: float, value: int) -> int:
    """Offer one message as the link would, with the policies as they are now; the rows it stored."""
    rec.apply(load_policies())
    rec.offer(TOPIC, "std_msgs/Int32", {"data": value}, t)
    return rec.flush_sync(rec.take())


def test_it_uses_the_global_interval_unless_the_topic_has_its_own(db, settings):
    settings.HISTORY_DEFAULT_INTERVAL_S = 5.0
    policy_upsert(topic="/a", msg_type="std_msgs/Int32", mode=Mode.PERIODIC)
    policy_upsert(topic="/b", msg_type="std_msgs/Int32", mode=Mode.PERIODIC, interval_s=0.5)

    assert load_policies()["/a"].interval_s == 5.0
    default_interval_set(seconds=2.0)
    policies = load_policies()
    assert policies["/a"].interval_s == 2.0
    assert policies["/b"].interval_s == 0.5


def test_it_applies_interval_changes_at_run_time(db):
    default_interval_set(seconds=10.0)
    policy_upsert(topic=TOPIC, msg_type="std_msgs/Int32", mode=Mode.PERIODIC)
    t0 = time.time() - 100
    rec = Recorder()

    assert _stored(rec, t0, 1) == 1
    assert _stored(rec, t0 + 2, 2) == 0  # 2 s < 10 s default

    default_interval_set(seconds=1.0)
    assert _stored(rec, t0 + 2, 2) == 1  # the new default wins at once

    policy_upsert(topic=TOPIC, interval_s=30.0)  # the topic's own interval beats the default
    assert _stored(rec, t0 + 4, 3) == 0
    assert _stored(rec, t0 + 33, 4) == 1

    assert list(Sample.objects.filter(topic=TOPIC).order_by("received_at").values_list("data", flat=True)) == [
        {"data": 1}, {"data": 2}, {"data": 4}
    ]


def test_it_never_stores_the_same_message_twice(db):
    policy_upsert(topic=TOPIC, msg_type="std_msgs/Int32", mode=Mode.PERIODIC, interval_s=0.1)
    rec = Recorder()
    t = time.time()

    assert _stored(rec, t, 1) == 1
    assert _stored(rec, t, 1) == 0  # the same message again (a resent one) adds nothing
    assert Sample.objects.filter(topic=TOPIC).count() == 1


def test_it_ignores_topics_that_are_off_and_keeps_every_message_of_the_others(db):
    policy_upsert(topic=TOPIC, msg_type="std_msgs/Int32", mode=Mode.OFF)
    rec = Recorder()
    t = time.time()
    assert _stored(rec, t, 1) == 0
    policy_upsert(topic=TOPIC, mode=Mode.EVERY)
    assert _stored(rec, t, 1) == 1
    assert _stored(rec, t + 0.001, 2) == 1


def test_it_adds_discovered_topics_once_and_keeps_existing_policies(db):
    policy_upsert(topic="/known", msg_type="std_msgs/String", mode=Mode.EVERY)

    added = policies_add_discovered(topics=[("/known", "std_msgs/String"), ("/new", "nav_msgs/Odometry")])

    assert added == ["/new"]
    assert TopicPolicy.objects.get(topic="/known").mode == Mode.EVERY
    assert TopicPolicy.objects.get(topic="/new").mode == Mode.OFF


def test_it_refuses_an_unknown_mode(db):
    from django.core.exceptions import ValidationError

    with pytest.raises(ValidationError):
        policy_upsert(topic=TOPIC, mode="sometimes")


def test_it_has_one_settings_row(db):
    assert RecordingSettings.load().pk == RecordingSettings.load().pk == 1
