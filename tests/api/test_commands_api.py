"""Each command endpoint changes the simulated robot as the real one would, and is audited."""

from __future__ import annotations

import pytest

from robot import interface as ri
from tests.commands.support import last_audit, motor_calls, received, sent_to_robot, wait_state
from tests.helpers import wait_until

pytestmark = pytest.mark.django_db


def test_it_switches_to_manual_with_the_server_strategy(operator_api, robot, settings):
    settings.MODE_COMMANDER = "server"
    res = operator_api.post("/api/robot/mode/", {"mode": "manual"}, format="json")
    assert res.status_code == 200, res.json()
    assert res.json()["ok"] is True
    state = wait_state(robot, lambda s: s["smach_state"] == "manual", "state manual")
    assert state["emotion_system"] is False
    # The server ran the commander's sequence itself and did not ask the robot's commander; already
    # in suspension, it needed no `aborted` to get there.
    assert received(robot, "register_event") == [{"data": "manual_start"}]
    assert received(robot, "emotional_controller") == [{"data": "OFF"}]
    assert received(robot, "robot_mode") == []
    entry = last_audit()
    assert (entry.username, entry.source, entry.action, entry.params, entry.ok) == (
        "otto", "api", "mode", {"mode": "manual"}, True)


def test_it_switches_to_behaviour_with_the_robot_strategy(operator_api, robot, settings):
    settings.MODE_COMMANDER = "robot"
    robot.call(lambda: robot.robot.emotion_node.__setattr__("enabled", False))
    res = operator_api.post("/api/robot/mode/", {"mode": "behaviour"}, format="json")
    assert res.status_code == 200, res.json()
    state = wait_state(robot, lambda s: s["smach_top"] == "behaviour", "state behaviour")
    assert state["smach_state"] == "idle"
    wait_state(robot, lambda s: s["emotion_system"] is True, "emotion system on")
    # Only the mode string went out; the robot's commander did the rest.
    assert received(robot, "robot_mode") == [{"data": "behaviour"}]
    assert received(robot, "register_event") == []
    assert received(robot, "emotional_controller") == []


@pytest.mark.parametrize("strategy", ["server", "robot"])
def test_it_stops_into_suspension_from_demo(operator_api, robot, settings, strategy):
    settings.MODE_COMMANDER = strategy
    assert operator_api.post("/api/robot/mode/", {"mode": "demo"}, format="json").status_code == 200
    wait_state(robot, lambda s: s["smach_state"] == "demo", "state demo")
    assert operator_api.post("/api/robot/mode/", {"mode": "stop"}, format="json").status_code == 200
    state = wait_state(robot, lambda s: s["smach_state"] == "suspension", "state suspension")
    assert state["emotion_system"] is False


def test_it_registers_an_event(operator_api, robot):
    res = operator_api.post("/api/robot/event/", {"event": "demo_start"}, format="json")
    assert res.status_code == 200
    wait_state(robot, lambda s: s["smach_state"] == "demo", "state demo")
    assert received(robot, "register_event") == [{"data": "demo_start"}]


def test_it_speaks_trimmed_text(operator_api, robot):
    spoken = robot.snapshot()["state"]["tts_spoken"]
    res = operator_api.post("/api/robot/speech/", {"text": "  Hello there  "}, format="json")
    assert res.status_code == 200
    wait_state(robot, lambda s: s["tts_spoken"] == spoken + 1, "speech finished")
    assert received(robot, "text_to_speech") == [{"data": "Hello there"}]


def test_it_sets_an_emotion_preset(operator_api, robot):
    robot.call(lambda: robot.robot.emotion_node.__setattr__("enabled", False))  # no drift during the check
    res = operator_api.post("/api/robot/emotion/", {"emotion": "puzzled"}, format="json")
    assert res.status_code == 200
    state = wait_state(robot, lambda s: s["emotion"]["name"] == "puzzled", "emotion puzzled")
    assert state["emotion"]["pad"] == pytest.approx(list(ri.EMOTION_PRESETS["puzzled"]), abs=0.05)


@pytest.mark.parametrize("on", [False, True])
def test_it_switches_the_emotion_system(operator_api, robot, on):
    robot.call(lambda: robot.robot.emotion_node.__setattr__("enabled", not on))
    res = operator_api.post("/api/robot/emotion-system/", {"on": on}, format="json")
    assert res.status_code == 200
    wait_state(robot, lambda s: s["emotion_system"] is on, f"emotion system {on}")
    assert received(robot, "emotional_controller") == [{"data": "ON" if on else "OFF"}]


def test_it_plays_a_sound_clip(operator_api, robot):
    res = operator_api.post("/api/robot/playback/", {"clip": "laugh"}, format="json")
    assert res.status_code == 200
    wait_state(robot, lambda s: s["playing"] == "laugh", "clip playing")
    assert received(robot, "playback") == [{"data": "laugh"}]


def test_it_sets_the_dome_mode(operator_api, robot):
    res = operator_api.post("/api/robot/dome/", {"mode": "rainbow"}, format="json")
    assert res.status_code == 200
    wait_state(robot, lambda s: s["dome"] == "rainbow", "dome rainbow")


def test_it_switches_the_motors_and_shows_the_service_result(operator_api, robot):
    res = operator_api.post("/api/robot/motors/", {"enabled": False}, format="json")
    assert res.status_code == 200
    assert "/RosAria/disable_motors ok" in res.json()["outcome"]
    assert robot.snapshot()["state"]["motors"] is False
    res = operator_api.post("/api/robot/motors/", {"enabled": True}, format="json")
    assert res.status_code == 200
    assert robot.snapshot()["state"]["motors"] is True
    assert motor_calls(robot) == 2


def test_it_reports_a_failed_motors_service_call(operator_api, robot, settings):
    settings.ROBOT_SERVICES = {"disable_motors": "/RosAria/no_such_service"}
    ri.reload()
    res = operator_api.post("/api/robot/motors/", {"enabled": False}, format="json")
    assert res.status_code == 502
    assert res.json()["code"] == "failed"
    assert "/RosAria/no_such_service" in res.json()["detail"] and "does not exist" in res.json()["detail"]
    assert robot.snapshot()["state"]["motors"] is True
    entry = last_audit()
    assert (entry.action, entry.ok, entry.error_code) == ("motors", False, "failed")


def test_it_answers_504_when_the_motors_service_does_not_answer(operator_api, robot, settings):
    from websockets.sync.client import connect

    # A node that advertises the service and never answers it.
    with connect(robot.url) as silent:
        silent.send('{"op": "advertise_service", "service": "/slow/enable", "type": "std_srvs/Empty"}')
        wait_until(lambda: robot.call(lambda: "/slow/enable" in robot.robot.bus.client_services),
                   what="service advertised")
        settings.ROBOT_SERVICES = {"enable_motors": "/slow/enable"}
        settings.ROBOT_REQUEST_TIMEOUT_S = 0.8
        ri.reload()
        res = operator_api.post("/api/robot/motors/", {"enabled": True}, format="json")
    assert res.status_code == 504, res.json()
    assert res.json()["code"] == "timeout"
    assert "did not answer" in res.json()["detail"]
    assert last_audit().error_code == "timeout"


def test_it_audits_page_and_token_sources(client, operator, robot):
    from tests.conftest import PASSWORD

    token = client.post("/api/auth/token/", {"username": "otto", "password": PASSWORD},
                        content_type="application/json").json()["token"]
    res = client.post("/api/robot/speech/", {"text": "from a script"}, content_type="application/json",
                      HTTP_AUTHORIZATION=f"Token {token}")
    assert res.status_code == 200
    assert last_audit().source == "api"
    client.force_login(operator)
    res = client.post("/api/robot/speech/", {"text": "from the page"}, content_type="application/json")
    assert res.status_code == 200
    assert last_audit().source == "page"
    wait_until(lambda: sent_to_robot(robot)["text_to_speech"] == 2, what="both texts arrived")
    assert [m["data"] for m in received(robot, "text_to_speech")] == ["from a script", "from the page"]
