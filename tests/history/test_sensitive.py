"""Sound and topics an admin marks sensitive are for operators: viewers are refused them in
history, plots, exports and on the topics page; operators read them as before."""

from __future__ import annotations

import asyncio
import json
import time

import pytest
from channels.db import database_sync_to_async
from django.test import Client

from history.models import Mode, TopicPolicy
from history.storage import write_rows
from robot import interface as ri
from robot.models import AuditEntry
from tests.helpers import receive_until, ws_communicator

MARKED = "/history_test/secret"
MIC = ri.topic("audio").name


def _record(topic: str, msg_type: str, data: dict) -> float:
    t0 = time.time() - 60
    write_rows([(topic, msg_type, t0 + i, json.dumps(data)) for i in range(3)])
    return t0


@pytest.fixture
def marked(db):
    TopicPolicy.objects.create(topic=MARKED, msg_type="std_msgs/Float32", mode=Mode.EVERY, sensitive=True)
    return _record(MARKED, "std_msgs/Float32", {"data": 1.5})


READS = [("/api/history/samples/", {"field": "data"}), ("/api/history/export/", {"format": "csv"}),
         ("/api/history/messages/", {})]


@pytest.mark.parametrize(("path", "extra"), READS)
def test_a_viewer_is_refused_a_marked_topic_and_an_operator_reads_it(viewer_api, operator_api, marked, path, extra):
    params = {"topic": MARKED, "start": marked, "end": marked + 10, **extra}
    refused = viewer_api.get(path, params)
    assert refused.status_code == 403
    assert refused.json()["code"] == "permission_denied" and "operators only" in refused.json()["detail"]
    assert operator_api.get(path, params).status_code == 200


@pytest.mark.parametrize(("path", "extra"), READS)
def test_a_viewer_is_refused_recorded_sound(viewer_api, db, path, extra):
    t0 = _record(MIC, "audio_common_msgs/AudioData", {"data": "AAAA"})
    res = viewer_api.get(path, {"topic": MIC, "start": t0, "end": t0 + 10, **extra})
    assert res.status_code == 403


def test_marking_a_topic_sensitive_is_audited(admin_user, db):
    TopicPolicy.objects.create(topic=MARKED, msg_type="std_msgs/Float32", mode=Mode.OFF)
    client = Client()
    client.force_login(admin_user)
    policy = TopicPolicy.objects.get(topic=MARKED)
    res = client.post(f"/admin/history/topicpolicy/{policy.pk}/change/", {
        "topic": MARKED, "msg_type": "std_msgs/Float32", "mode": "off", "interval_s": "", "retention_s": "",
        "max_message_bytes": "", "sensitive": "on"})
    assert res.status_code == 302, res.content.decode()[:2000]
    entry = AuditEntry.objects.filter(action="history.policy").latest("pk")
    assert entry.params["from"]["sensitive"] is False and entry.params["to"]["sensitive"] is True


@pytest.mark.django_db(transaction=True)
async def test_a_viewer_cannot_watch_a_marked_topic_on_the_topics_page(link, sim, viewer, operator):
    name = ri.topic("tf").name
    await database_sync_to_async(TopicPolicy.objects.create)(topic=name, msg_type="tf2_msgs/TFMessage",
                                                             sensitive=True)
    page = ws_communicator(viewer)
    assert (await page.connect(timeout=10))[0]
    await page.send_json_to({"action": "watch_topic", "topic": name})
    refusal = await receive_until(page, lambda f: f.get("kind") == "error", timeout=10)
    assert refusal["code"] == "forbidden" and "operators only" in refusal["message"]
    await page.send_json_to({"action": "watch", "keys": ["tf"]})
    assert "Cannot watch: tf" in (await receive_until(page, lambda f: f.get("kind") == "error", timeout=10))["message"]
    assert sim.subscription_count(name) == 0
    await page.disconnect()

    operators = ws_communicator(operator)
    assert (await operators.connect(timeout=10))[0]
    await operators.send_json_to({"action": "watch_topic", "topic": name})
    await receive_until(operators, lambda f: f.get("kind") == "watching", timeout=10)
    await operators.disconnect()


@pytest.mark.django_db(transaction=True)
async def test_a_viewer_watching_a_topic_stops_getting_it_once_an_admin_marks_it_sensitive(link, sim, viewer):
    from dashboard.consumers import RECHECK_S
    from robot.link.watching import echo_key

    name, key = ri.topic("tf").name, echo_key(ri.topic("tf").name)
    page = ws_communicator(viewer)
    assert (await page.connect(timeout=10))[0]
    await page.send_json_to({"action": "watch_topic", "topic": name})
    await receive_until(page, lambda f: f.get("kind") == "update" and f.get("key") == key, timeout=10)
    await database_sync_to_async(TopicPolicy.objects.create)(topic=name, msg_type="tf2_msgs/TFMessage",
                                                             sensitive=True)
    refusal = await receive_until(page, lambda f: f.get("kind") == "error", timeout=RECHECK_S * 2 + 5)
    assert (refusal["code"], refusal["topic"]) == ("forbidden", name) and "operators only" in refusal["message"]
    await asyncio.sleep(1.5)  # tf goes on at 10 Hz at the robot
    later = []
    while not await page.receive_nothing(timeout=0.1):
        frame = await page.receive_json_from()
        later.extend(frame.get("updates", [frame]))
    assert [f for f in later if f.get("key") == key] == []
    await page.disconnect()
