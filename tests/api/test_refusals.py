"""Invalid input, viewers, anonymous callers and an offline robot: the documented status, and
nothing reaches the robot."""

from __future__ import annotations

import pytest

from robot.models import AuditEntry
from tests.commands.support import ENDPOINTS, last_audit, only_the_marker_arrived, sent_to_robot
from tests.helpers import wait_until

pytestmark = pytest.mark.django_db

INVALID = [
    ("/api/robot/mode/", {"mode": "dance"}, "mode"),
    ("/api/robot/mode/", {}, "mode"),
    ("/api/robot/event/", {"event": ""}, "event"),
    ("/api/robot/event/", {"event": "rm -rf"}, "event"),
    ("/api/robot/event/", {"event": "x" * 65}, "event"),
    ("/api/robot/speech/", {"text": "   "}, "text"),
    ("/api/robot/speech/", {"text": "a" * 501}, "text"),
    ("/api/robot/speech/", {"text": 42}, "text"),
    ("/api/robot/emotion/", {"emotion": "furious"}, "emotion"),
    ("/api/robot/emotion-system/", {"on": "yes"}, "on"),
    ("/api/robot/motors/", {"enabled": 1}, "enabled"),
    ("/api/robot/motors/", {}, "enabled"),
    ("/api/robot/playback/", {"clip": "../../etc/passwd"}, "clip"),
    ("/api/robot/dome/", {"mode": "disco"}, "mode"),
]


def test_it_refuses_invalid_input_naming_the_field(operator_api, robot):
    # One robot for all cases: starting a simulator per case would dominate the run time.
    for path, body, field in INVALID:
        res = operator_api.post(path, body, format="json")
        assert res.status_code == 400, (path, body, res.json())
        assert (res.json()["code"], res.json()["field"]) == ("invalid", field)
        assert res.json()["detail"].startswith(f"{field}:")
        entry = last_audit()
        assert (entry.ok, entry.error_code, entry.username) == (False, "invalid", "otto")
        assert entry.params == {field: body.get(field)}
    assert only_the_marker_arrived(robot, operator_api), sent_to_robot(robot)


def test_it_accepts_exactly_500_characters_of_speech(operator_api, robot):
    assert operator_api.post("/api/robot/speech/", {"text": "a" * 500}, format="json").status_code == 200


def test_it_forbids_viewers_and_audits_the_attempt(viewer_api, operator_api, robot):
    for path, body in ENDPOINTS.items():
        res = viewer_api.post(path, body, format="json")
        assert res.status_code == 403, path
        assert res.json()["code"] == "forbidden"
        entry = last_audit()
        assert (entry.username, entry.ok, entry.error_code) == ("vera", False, "forbidden")
    assert only_the_marker_arrived(robot, operator_api), sent_to_robot(robot)


def test_it_asks_anonymous_callers_to_authenticate(anon_api, operator_api, robot):
    for path, body in ENDPOINTS.items():
        res = anon_api.post(path, body, format="json")
        assert res.status_code == 401, path
        assert res["WWW-Authenticate"] == "Token"
    assert not AuditEntry.objects.exists()
    assert only_the_marker_arrived(robot, operator_api), sent_to_robot(robot)


def test_it_answers_503_when_offline_and_fires_nothing_later(operator_api, sim, link_thread):
    from simulator.harness import SimThread

    port = sim.port
    sim.stop()
    wait_until(lambda: not link_thread.connected, timeout=10, what="link offline")
    for path, body in ENDPOINTS.items():
        res = operator_api.post(path, body, format="json")
        assert res.status_code == 503, (path, res.json())
        assert res.json()["code"] == "offline"
        assert "offline" in res.json()["detail"].lower()
    assert AuditEntry.objects.filter(ok=False, error_code="offline").count() == len(ENDPOINTS)
    with SimThread(port=port, video_port=0, startup_s=0.5) as revived:
        wait_until(lambda: link_thread.connected, timeout=15, what="link back online")
        # The refused commands were not queued to fire after the reconnect.
        assert only_the_marker_arrived(revived, operator_api), sent_to_robot(revived)


# Two requests on two threads: each needs the committed users and presets.
@pytest.mark.django_db(transaction=True)
def test_it_refuses_a_second_mode_change_while_one_runs(operator, robot):
    import threading

    from rest_framework.test import APIClient

    first, second = APIClient(), APIClient()
    first.force_authenticate(operator)
    second.force_authenticate(operator)
    answers: dict[str, object] = {}
    runner = threading.Thread(target=lambda: answers.update(first=first.post("/api/robot/mode/", {"mode": "demo"},
                                                                             format="json")))
    runner.start()
    # The server strategy is inside its 0.5 s pause once the emotion system switch has reached the robot.
    wait_until(lambda: robot.received_count("/cyborg_controller/emotional_controller") == 1, what="first step")
    res = second.post("/api/robot/mode/", {"mode": "manual"}, format="json")
    runner.join(10)
    assert res.status_code == 409
    assert res.json() == {"detail": "A mode change to demo is already in progress; try again in a moment.",
                          "code": "busy"}
    assert answers["first"].status_code == 200
    wait_until(lambda: robot.received_count("/cyborg_controller/register_event") == 1, what="demo_start")
    assert [m["data"] for m in robot.received("/cyborg_controller/register_event")] == ["demo_start"]
    assert last_audit().error_code in ("busy", "")  # both entries are written; order depends on timing
    assert AuditEntry.objects.filter(action="mode", error_code="busy").count() == 1


def test_it_throttles_commands_per_user(operator_api, admin_api, robot, settings):
    settings.COMMAND_THROTTLE_RATE = "2/min"
    for _ in range(2):
        assert operator_api.post("/api/robot/event/", {"event": "aborted"}, format="json").status_code == 200
    res = operator_api.post("/api/robot/event/", {"event": "aborted"}, format="json")
    assert res.status_code == 429
    assert res.json()["code"] == "throttled"
    # Another user has a budget of their own; their event is the marker that all earlier ones arrived.
    assert admin_api.post("/api/robot/event/", {"event": "suspend"}, format="json").status_code == 200
    wait_until(lambda: robot.received_count("/cyborg_controller/register_event") >= 3, what="the admin's event")
    assert [m["data"] for m in robot.received("/cyborg_controller/register_event")] == ["aborted", "aborted",
                                                                                          "suspend"]
