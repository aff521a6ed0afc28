import json
import time

import pytest
from django.test import Client

from history.models import Mode, TopicPolicy
from history.selectors import numeric_fields, state_timeline
from history.sessions import SESSION_TOPIC, SESSION_TYPE, SessionNotes
from history.storage import utc, write_rows
from robot import interface as ri

pytestmark = pytest.mark.postgres  # the history store: its writes, queries and rollups differ by engine


def _client(user) -> Client:
    client = Client()
    client.force_login(user)
    return client


def test_it_shows_the_plots_page_with_presets_to_viewers(viewer):
    TopicPolicy.objects.create(topic=ri.topic("battery_soc").name, msg_type="std_msgs/Float32", mode=Mode.PERIODIC)
    write_rows([(ri.topic("battery_soc").name, "std_msgs/Float32", time.time(), '{"data": 0.8}')])

    res = _client(viewer).get("/history/")

    assert res.status_code == 200
    html = res.content.decode()
    assert "vendor/uplot/uPlot.iife.min.js" in html and "js/history.js" in html
    assert "Recording policies are set by an admin." in html
    config = json.loads(html.split('id="history-config" type="application/json">')[1].split("</script>")[0])
    assert config["presets"]["battery"]["topic"] == ri.topic("battery_soc").name
    assert config["presets"]["pad"]["fields"] == ["current_pleasure", "current_arousal", "current_dominance"]
    assert config["topics"] == [{"topic": ri.topic("battery_soc").name, "msg_type": "std_msgs/Float32",
                                 "fields": ["data"], "text": False, "units": {"data": {"unit": "%", "scale": 100.0}}}]


def test_it_links_admins_to_the_policies(admin_user):
    res = _client(admin_user).get("/history/")

    assert "/admin/history/topicpolicy/" in res.content.decode()


def test_it_sends_anonymous_visitors_to_log_in(client, db):
    res = client.get("/history/")

    assert res.status_code == 302
    assert "/accounts/login/" in res["Location"]


def test_it_finds_numeric_fields_including_small_arrays():
    msg = {"header": {"seq": 3, "frame_id": "map"}, "pose": {"x": 1.0}, "ok": True, "covariance": [0.0] * 36,
           "rgb": [1, 2, 3], "name": "x"}

    assert numeric_fields(msg) == ["header.seq", "pose.x", "ok", "rgb.0", "rgb.1", "rgb.2"]


def _state_changes(t0: float, changes: list[tuple[float, str, str]]) -> None:
    topic = ri.topic("state_change")
    write_rows([(topic.name, topic.type, t0 + at, json.dumps({"event": "e", "from_system_state": a,
                                                               "to_system_state": b}))
                for at, a, b in changes])


def test_it_computes_time_spent_per_state(db):
    t0 = time.time() - 3600
    _state_changes(t0, [(-50, "startup", "suspension"), (10, "suspension", "idle"), (40, "idle", "behaviour"),
                        (70, "behaviour", "idle")])

    timeline = state_timeline(start=utc(t0), end=utc(t0 + 100))

    assert timeline.totals == pytest.approx({"suspension": 10, "idle": 30 + 30, "behaviour": 30})
    assert [s["state"] for s in timeline.segments] == ["suspension", "idle", "behaviour", "idle"]
    assert timeline.segments[0]["start"] == pytest.approx(t0)


def test_it_counts_only_the_span_the_data_covers(db):
    t0 = time.time() - 3600
    _state_changes(t0, [(20, "startup", "suspension")])

    timeline = state_timeline(start=utc(t0), end=utc(t0 + 60))

    # How long startup ran before t0 + 20 is unknown: nothing was recorded before it.
    assert timeline.totals == pytest.approx({"suspension": 40}, abs=0.01)


def test_it_stops_the_timeline_at_now(db):
    now = time.time()
    _state_changes(now - 30, [(0, "idle", "demo")])

    timeline = state_timeline(start=utc(now - 60), end=utc(now + 3600), now=now)

    assert timeline.totals == pytest.approx({"demo": 30}, abs=0.01)


def _battery_every_10_s(t0: float, duration_s: float) -> None:
    topic = ri.topic("battery_soc")
    write_rows([(topic.name, topic.type, t0 + i * 10, '{"data": 0.8}') for i in range(int(duration_s // 10) + 1)])


def test_it_shows_ten_minutes_for_a_robot_that_ran_ten_minutes_in_the_last_day(db):
    now = time.time()
    began = now - 23 * 3600
    _battery_every_10_s(began, 600)
    _state_changes(began, [(15, "startup", "suspension"), (300, "suspension", "idle")])

    timeline = state_timeline(start=utc(now - 86400), end=utc(now), now=now)

    assert timeline.totals == pytest.approx({"startup": 15, "suspension": 285, "idle": 300}, abs=0.01)
    assert timeline.spans == [pytest.approx((began, began + 600), abs=0.01)]


def test_it_leaves_out_the_time_the_robot_was_away(db):
    t0 = time.time() - 7200
    _battery_every_10_s(t0, 300)
    _battery_every_10_s(t0 + 3600, 300)
    _state_changes(t0, [(0, "startup", "suspension"), (3600, "suspension", "startup"),
                        (3615, "startup", "suspension")])

    timeline = state_timeline(start=utc(t0 - 60), end=utc(t0 + 3900))

    assert timeline.totals == pytest.approx({"suspension": 300 + 285, "startup": 15}, abs=0.01)
    assert [s["state"] for s in timeline.segments] == ["suspension", "startup", "suspension"]


def test_it_serves_the_timeline(viewer_api):
    t0 = time.time() - 3600
    _state_changes(t0, [(10, "suspension", "idle")])

    res = viewer_api.get("/api/history/timeline/", {"start": t0, "end": t0 + 20})

    assert res.status_code == 200
    assert res.json()["totals"] == pytest.approx({"idle": 10}, abs=0.01)
    assert res.json()["counts"] == {"idle": 1}
    assert res.json()["spans"] == [{"start": pytest.approx(t0 + 10, abs=0.01), "end": pytest.approx(t0 + 20)}]


def test_it_explains_an_empty_history(client, viewer):
    client.force_login(viewer)
    body = client.get("/history/").content.decode()
    assert 'id="history-empty"' in body
    assert "recording policies</a>" not in body.split('id="history-empty"')[1].split("</p>")[0]


def test_it_serves_a_text_topics_messages_newest_first(viewer_api):
    topic = ri.topic("text_to_speech")
    t0 = time.time() - 60
    write_rows([(topic.name, topic.type, t0 + i, json.dumps({"data": f"line {i}"})) for i in range(5)])

    res = viewer_api.get("/api/history/messages/", {"topic": topic.name, "start": t0 - 1, "limit": 3})

    assert res.status_code == 200
    body = res.json()
    assert [m["data"]["data"] for m in body["messages"]] == ["line 4", "line 3", "line 2"]
    assert body["truncated"] is True
    assert body["messages"][0]["t"] == pytest.approx(t0 + 4, abs=0.001)


def test_it_marks_text_topics_for_the_table_view(viewer):
    speech, battery = ri.topic("text_to_speech"), ri.topic("battery_soc")
    for t in (speech, battery):
        TopicPolicy.objects.create(topic=t.name, msg_type=t.type, mode=Mode.EVERY)
    write_rows([(speech.name, speech.type, time.time(), '{"data": "hi"}'),
                (battery.name, battery.type, time.time(), '{"data": 0.5}')])

    html = _client(viewer).get("/history/").content.decode()

    config = json.loads(html.split('id="history-config" type="application/json">')[1].split("</script>")[0])
    assert {t["topic"]: (t["fields"], t["text"]) for t in config["topics"]} == {
        speech.name: ([], True), battery.name: (["data"], False)}


def _link(t0: float, events: list[tuple[float, bool]]) -> None:
    write_rows([(SESSION_TOPIC, SESSION_TYPE, t0 + at, json.dumps({"connected": connected}))
                for at, connected in events])


def test_it_books_a_robot_restart_as_offline_then_startup_and_counts_each_startup(db):
    t0 = time.time() - 3600
    _battery_every_10_s(t0, 300)
    # Started, went to demo; the robot restarted at 100 (back at 110) and left startup at 125.
    _state_changes(t0, [(0, "suspension", "startup"), (15, "startup", "suspension"), (40, "suspension", "demo"),
                        (125, "startup", "suspension")])
    _link(t0, [(100, False), (110, True)])

    timeline = state_timeline(start=utc(t0), end=utc(t0 + 200))

    assert [s["state"] for s in timeline.segments] == ["startup", "suspension", "demo", "offline", "startup",
                                                       "suspension"]
    assert timeline.totals == pytest.approx({"startup": 15 + 15, "suspension": 25 + 75, "demo": 60, "offline": 10},
                                            abs=0.01)
    assert timeline.counts == {"startup": 2, "suspension": 2, "demo": 1, "offline": 1}


def test_it_books_an_outage_the_recorder_saw_as_offline_though_nothing_else_was_recorded(db):
    t0 = time.time() - 3600
    _battery_every_10_s(t0, 60)
    _state_changes(t0, [(0, "startup", "suspension")])
    _link(t0, [(60, False), (120, False), (180, False), (240, False), (270, True)])
    _battery_every_10_s(t0 + 270, 60)

    timeline = state_timeline(start=utc(t0), end=utc(t0 + 330))

    assert timeline.totals == pytest.approx({"suspension": 60, "offline": 210}, abs=0.01)


def test_it_knows_no_state_after_a_reconnect_until_the_robot_names_one(db):
    t0 = time.time() - 3600
    _battery_every_10_s(t0, 100)
    _state_changes(t0, [(0, "startup", "demo"), (80, "manual", "suspension")])
    _link(t0, [(30, True)])  # the server (re)connected at 30: from then on "demo" is not known

    timeline = state_timeline(start=utc(t0), end=utc(t0 + 100))

    assert [s["state"] for s in timeline.segments] == ["demo", "manual", "suspension"]
    assert timeline.totals == pytest.approx({"demo": 30, "manual": 50, "suspension": 20}, abs=0.01)


def test_the_recorder_notes_each_change_of_the_link_and_beats_while_the_robot_is_away():
    notes = SessionNotes()

    def row(connected: bool, t: float):
        return [(SESSION_TOPIC, SESSION_TYPE, {"connected": connected}, t)]

    assert notes.note(connected=False, since=5.0, now=10.0) == row(False, 5.0)
    assert notes.note(connected=False, since=5.0, now=30.0) == []
    assert notes.note(connected=False, since=5.0, now=70.0) == row(False, 70.0)
    assert notes.note(connected=True, since=71.5, now=72.0) == row(True, 71.5)
    assert notes.note(connected=True, since=71.5, now=900.0) == []
