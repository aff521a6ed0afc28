import csv
import io
import json
import time

import pytest

from history.models import Mode, RecordingSettings, TopicPolicy
from history.storage import write_rows

pytestmark = pytest.mark.postgres  # the history store: its writes, queries and rollups differ by engine

TOPIC = "/history_test/api"


def _samples(n: int = 30, t0: float | None = None) -> float:
    t0 = t0 or time.time() - 600
    write_rows([(TOPIC, "cyborg_controller/EmotionalState", t0 + i,
                 json.dumps({"to_emotional_state": "curious", "current_pleasure": i / 10, "pose": {"x": i}}))
                for i in range(n)])
    return t0


def test_it_lists_policies_to_viewers(viewer_api, db):
    TopicPolicy.objects.create(topic=TOPIC, msg_type="std_msgs/Int32", mode=Mode.PERIODIC, interval_s=3)

    res = viewer_api.get("/api/history/topics/")

    assert res.status_code == 200
    assert res.json()["topics"][0]["effective_interval_s"] == 3


def test_it_refuses_policy_changes_from_operators(operator_api):
    res = operator_api.patch("/api/history/topics/", {"default_interval_s": 1}, format="json")

    assert res.status_code == 403
    assert res.json()["code"] == "permission_denied"
    assert RecordingSettings.load().default_interval_s == 0


def test_it_lets_admins_change_the_default_and_topics(admin_api):
    body = {"default_interval_s": 2.5,
            "topics": [{"topic": TOPIC, "msg_type": "std_msgs/Int32", "mode": "periodic"},
                       {"topic": "/other", "msg_type": "std_msgs/String", "mode": "every", "retention_s": 3600}]}

    res = admin_api.patch("/api/history/topics/", body, format="json")

    assert res.status_code == 200
    by_topic = {t["topic"]: t for t in res.json()["topics"]}
    assert res.json()["default_interval_s"] == 2.5
    assert by_topic[TOPIC]["effective_interval_s"] == 2.5
    assert by_topic["/other"]["retention_s"] == 3600


def test_it_refuses_a_bad_mode(admin_api):
    res = admin_api.patch("/api/history/topics/", {"topics": [{"topic": TOPIC, "mode": "often"}]}, format="json")

    assert res.status_code == 400
    assert res.json()["field"] == "topics.0.mode"


def test_it_serves_a_downsampled_series(viewer_api):
    t0 = _samples(30)

    res = viewer_api.get("/api/history/samples/", {"topic": TOPIC, "field": "current_pleasure", "start": t0,
                                                   "end": t0 + 30, "max_points": 10})

    assert res.status_code == 200
    body = res.json()
    assert len(body["t"]) <= 10
    assert max(body["max"]) == pytest.approx(2.9)
    assert sum(body["count"]) == 30


@pytest.mark.parametrize(("params", "field"), [
    ({"field": "x; drop table"}, "field"),
    ({"field": "data", "start": "yesterday"}, "start"),
    ({"field": "data", "start": "2030-01-02T00:00:00Z", "end": "2030-01-01T00:00:00Z"}, "start"),
])
def test_it_refuses_bad_series_queries(viewer_api, params, field):
    res = viewer_api.get("/api/history/samples/", {"topic": TOPIC, **params})

    assert res.status_code == 400
    assert res.json()["field"] == field


def test_it_refuses_anonymous_callers(anon_api, db):
    assert anon_api.get("/api/history/samples/", {"topic": TOPIC, "field": "data"}).status_code in (401, 403)
    assert anon_api.get("/api/history/export/", {"topic": TOPIC}).status_code in (401, 403)


def _content(res) -> bytes:
    """Read the streamed body the way the ASGI server does (the view streams asynchronously)."""
    from asgiref.sync import async_to_sync

    async def collect() -> bytes:
        return b"".join([chunk async for chunk in res.streaming_content])

    return async_to_sync(collect)()


def test_it_exports_csv_with_scalar_columns(viewer_api):
    t0 = _samples(5)

    res = viewer_api.get("/api/history/export/", {"topic": TOPIC, "start": t0, "end": t0 + 10, "format": "csv"})

    assert res.status_code == 200
    assert res.streaming
    rows = list(csv.DictReader(io.StringIO(_content(res).decode())))
    assert len(rows) == 5
    assert rows[3]["current_pleasure"] == "0.3"
    assert rows[3]["pose.x"] == "3"
    assert json.loads(rows[3]["message"])["to_emotional_state"] == "curious"


def test_it_exports_json_lines(viewer_api):
    t0 = _samples(5)

    res = viewer_api.get("/api/history/export/", {"topic": TOPIC, "start": t0, "end": t0 + 10, "format": "jsonl"})

    records = [json.loads(line) for line in _content(res).decode().splitlines()]
    assert [r["msg"]["pose"]["x"] for r in records] == [0, 1, 2, 3, 4]
    assert records[0]["received_at"].endswith("+00:00")


def test_it_exports_mcap_that_the_mcap_reader_reads_back(viewer_api):
    from mcap.reader import make_reader

    t0 = _samples(2500)  # more than one streamed chunk

    res = viewer_api.get("/api/history/export/", {"topic": TOPIC, "start": t0, "end": t0 + 3000, "format": "mcap"})

    assert res.status_code == 200
    reader = make_reader(io.BytesIO(_content(res)))
    messages = list(reader.iter_messages())
    assert len(messages) == 2500
    schema, channel, message = messages[42]
    assert channel.topic == TOPIC and channel.message_encoding == "json"
    assert schema.name == "cyborg_controller/EmotionalState" and schema.encoding == "jsonschema"
    assert json.loads(schema.data)["properties"]["current_pleasure"] == {"type": "number"}
    assert json.loads(message.data)["pose"]["x"] == 42
    assert message.log_time == pytest.approx((t0 + 42) * 1e9, abs=1e3)
    assert reader.get_summary().statistics.message_count == 2500


def test_it_exports_an_empty_range_as_a_valid_file(viewer_api):
    res = viewer_api.get("/api/history/export/", {"topic": "/nothing", "format": "mcap"})

    from mcap.reader import make_reader

    assert list(make_reader(io.BytesIO(_content(res))).iter_messages()) == []


def test_it_refuses_an_unknown_export_format(viewer_api):
    res = viewer_api.get("/api/history/export/", {"topic": TOPIC, "format": "xlsx"})

    assert res.status_code == 400
    assert res.json()["field"] == "format"


def test_it_lists_recorded_topics_with_numeric_fields(viewer_api):
    TopicPolicy.objects.create(topic=TOPIC, msg_type="cyborg_controller/EmotionalState", mode=Mode.EVERY)
    _samples(2)

    res = viewer_api.get("/api/history/recorded/")

    assert sorted(res.json()["topics"][0]["fields"]) == ["current_pleasure", "pose.x"]  # jsonb reorders keys
