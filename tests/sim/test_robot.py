"""The simulated robot's behaviour, driven through unmodified roslibpy as the product drives the real one."""

from __future__ import annotations

import json
import math
import time

import pytest
import roslibpy
from roslibpy.ros1.actionlib import ActionClient, Goal

from robot import interface as ri
from simulator import SimThread, messages
from tests.sim.support import FAST, Inbox, subscribe, wait_until


def T(key: str) -> tuple[str, str]:
    t = ri.topic(key)
    return t.name, t.type


def sub(ros, key: str, **kw) -> Inbox:
    return subscribe(ros, *T(key), **kw)


def pub(ros, key: str, msg: dict) -> None:
    roslibpy.Topic(ros, *T(key)).publish(roslibpy.Message(msg))


def call(ros, key: str, args: dict | None = None) -> dict:
    s = ri.service(key)
    return roslibpy.Service(ros, s.name, s.type).call(roslibpy.ServiceRequest(args or {}), timeout=5)


def action_client(ros, key: str) -> ActionClient:
    a = ri.action(key)
    return ActionClient(ros, a.name, f"{a.type}Action")


def twist(v: float, w: float = 0.0) -> dict:
    return {"linear": {"x": v, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": w}}


def pose_msg(x: float, y: float, yaw: float) -> dict:
    return {"position": {"x": x, "y": y, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}


def set_pose(ros, sim, x: float, y: float, yaw: float) -> None:
    pub(ros, "initialpose", {"header": {"frame_id": "map"}, "pose": {"pose": pose_msg(x, y, yaw)}})
    wait_until(lambda: math.hypot(state(sim)["pose"]["x"] - x, state(sim)["pose"]["y"] - y) < 1e-6,
               what="initial pose applied")


def state(sim) -> dict:
    return sim.snapshot()["state"]


def drive(ros, v: float, w: float, seconds: float) -> None:
    topic = roslibpy.Topic(ros, *T("cmd_vel"))
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        topic.publish(roslibpy.Message(twist(v, w)))
        time.sleep(0.1)


def nav_goal(x: float, y: float, yaw: float = 0.0) -> roslibpy.Message:
    return roslibpy.Message({"target_pose": {"header": {"frame_id": "map"}, "pose": pose_msg(x, y, yaw)}})


# --- monitoring ---------------------------------------------------------------------------


def test_it_publishes_every_monitored_topic_with_a_valid_message(sim, ros):
    inboxes = {t.key: sub(ros, t.key) for t in ri.monitored_topics()}
    wait_until(lambda: sim.subscription_count(ri.topic("rosout").name) == 1)
    # event-like topics need something to happen
    pub(ros, "robot_mode", {"data": ri.Mode.MANUAL.value})
    pub(ros, "text_to_speech", {"data": "hello"})
    pub(ros, "playback", {"data": "hello_there"})
    pub(ros, "move_base_simple_goal", {"header": {"frame_id": "map"}, "pose": pose_msg(1.0, -1.0, 0.0)})
    for key, inbox in inboxes.items():
        inbox.wait(timeout=5, what=key)
        msg = inbox.items[0]
        messages.normalize(ri.topic(key).type, msg)  # raises if a field is missing, extra or mistyped


def test_it_publishes_pose_and_odom_at_the_configured_rate_with_wall_clock_stamps():
    with SimThread(**FAST, pose_rate_hz=20.0) as sim:
        ros = roslibpy.Ros(sim.host, sim.port)
        ros.run(timeout=10)
        try:
            odom = sub(ros, "odom")
            odom.wait(lambda items: len(items) >= 3)
            start = len(odom)
            time.sleep(1.0)
            rate = len(odom) - start
            assert 14 <= rate <= 24, rate
            msg, received = odom.items[-1], odom.times[-1]
            stamp = msg["header"]["stamp"]["secs"] + msg["header"]["stamp"]["nsecs"] * 1e-9
            assert 0 <= received - stamp < 0.5
        finally:
            ros.close()


def test_it_publishes_tf_at_a_high_rate_with_the_map_odom_base_link_chain(sim, ros):
    tf = sub(ros, "tf")
    tf.wait(lambda items: len(items) >= 2)
    start = len(tf)
    time.sleep(1.0)
    assert len(tf) - start >= 15
    frames = {(t["header"]["frame_id"], t["child_frame_id"]) for t in tf.items[-1]["transforms"]}
    assert frames == {("map", "odom"), ("odom", "base_link")}


def test_it_publishes_action_status_even_when_idle(sim, ros):
    status = subscribe(ros, f"{ri.action('move_base').name}/status", "actionlib_msgs/GoalStatusArray")
    status.wait(lambda items: len(items) >= 3)
    assert status.items[-1]["status_list"] == []
    action_client(ros, "navigation")  # raises unless a first /status arrives within 3 s


# --- driving --------------------------------------------------------------------------------


def test_it_drives_with_cmd_vel_and_stops_half_a_second_after_the_last_command(sim, ros):
    start = state(sim)["pose"]
    drive(ros, 0.5, 0.0, 1.0)
    moving = state(sim)
    assert moving["v"] == pytest.approx(0.5)
    travelled = math.hypot(moving["pose"]["x"] - start["x"], moving["pose"]["y"] - start["y"])
    assert 0.3 < travelled < 0.8
    # heading pi/2: forward is +y
    assert moving["pose"]["y"] > start["y"] + 0.3
    wait_until(lambda: state(sim)["v"] == 0.0, what="base stopped")
    stopped = state(sim)["pose"]
    time.sleep(0.2)
    assert state(sim)["pose"] == stopped


def test_it_ignores_cmd_vel_while_the_motors_are_disabled(sim, ros):
    motors = sub(ros, "motors_state")
    call(ros, "disable_motors")
    motors.wait_for(lambda m: m["data"] is False)
    start = state(sim)["pose"]
    drive(ros, 0.5, 0.5, 0.5)
    assert state(sim)["pose"] == start
    call(ros, "enable_motors")
    motors.wait_for(lambda m: m["data"] is True)
    drive(ros, 0.5, 0.0, 0.5)
    assert state(sim)["pose"] != start


def test_it_is_blocked_by_walls_and_reports_the_bump(sim, ros):
    bumpers = sub(ros, "bumper_state")
    rosout = sub(ros, "rosout")
    set_pose(ros, sim, 5.0, -6.2, -math.pi / 2)  # 0.65 m north of the south wall, facing it
    drive(ros, 1.0, 0.0, 1.5)
    y = state(sim)["pose"]["y"]
    assert -6.85 + 0.15 < y < -6.2
    bumpers.wait_for(lambda m: any(m["front_bumpers"]))
    rosout.wait_for(lambda m: m["level"] == 4 and "Bumper" in m["msg"])


def test_it_relocates_on_initialpose(sim, ros):
    poses = sub(ros, "robot_pose")
    pub(ros, "initialpose", {"header": {"frame_id": "map"}, "pose": {"pose": pose_msg(3.0, 2.0, 1.0)}})
    got = poses.wait_for(lambda m: abs(m["position"]["x"] - 3.0) < 1e-6)
    assert got["position"]["y"] == pytest.approx(2.0)
    assert 2 * math.atan2(got["orientation"]["z"], got["orientation"]["w"]) == pytest.approx(1.0)


# --- navigation -------------------------------------------------------------------------------


def test_it_reaches_a_move_base_goal_with_plan_feedback_and_result(sim, ros):
    plan = sub(ros, "plan")
    client = action_client(ros, "move_base")
    feedback: list = []
    goal = Goal(client, nav_goal(1.5, -1.0, 0.0))
    goal.on("feedback", feedback.append)
    goal.send()
    goal.wait(20)
    assert goal.status["status"] == 3  # SUCCEEDED
    s = state(sim)
    assert math.hypot(s["pose"]["x"] - 1.5, s["pose"]["y"] + 1.0) < 0.2
    assert abs(s["pose"]["yaw"]) < 0.15
    path = plan.wait(lambda items: next((m for m in items if len(m["poses"]) > 2), None))
    end = path["poses"][-1]["pose"]["position"]
    assert (end["x"], end["y"]) == pytest.approx((1.5, -1.0))
    assert feedback and "base_position" in feedback[0]


def test_it_cancels_a_move_base_goal_and_stops(sim, ros):
    client = action_client(ros, "move_base")
    goal = Goal(client, nav_goal(6.5, 5.2))
    goal.send()
    wait_until(lambda: state(sim)["v"] > 0, what="robot moving")
    goal.cancel()
    wait_until(lambda: goal.status and goal.status["status"] == 2, what="PREEMPTED")
    wait_until(lambda: state(sim)["v"] == 0.0, what="robot stopped")
    assert state(sim)["navigating"] is False


def test_it_aborts_a_goal_inside_a_pillar(sim, ros):
    client = action_client(ros, "move_base")
    goal = Goal(client, nav_goal(6.0, 1.0))  # a pillar's centre
    goal.send()
    goal.wait(5)
    assert goal.status["status"] == 4  # ABORTED


def test_it_preempts_the_current_goal_when_a_new_one_arrives(sim, ros):
    client = action_client(ros, "move_base")
    first = Goal(client, nav_goal(6.5, 5.2))
    first.send()
    wait_until(lambda: first.status and first.status["status"] == 1, what="first ACTIVE")
    second = Goal(client, nav_goal(0.5, -1.0, math.pi / 2))
    second.send()
    wait_until(lambda: first.status["status"] == 2, what="first PREEMPTED")
    second.wait(15)
    assert second.status["status"] == 3


def test_it_follows_move_base_simple_goal(sim, ros):
    pub(ros, "move_base_simple_goal", {"header": {"frame_id": "map"}, "pose": pose_msg(0.0, 0.0, math.pi / 2)})
    wait_until(lambda: state(sim)["goal"] is not None, what="goal accepted")
    wait_until(lambda: not state(sim)["navigating"] and abs(state(sim)["pose"]["y"]) < 0.2, timeout=10)


def test_it_navigates_to_a_named_location_and_reports_it(sim, ros):
    here = sub(ros, "current_location")
    set_pose(ros, sim, 5.0, -1.0, 0.0)
    client = action_client(ros, "navigation")
    feedback: list = []
    goal = Goal(client, roslibpy.Message({"order": "navigation_go_to", "location_name": "stage"}))
    goal.on("feedback", feedback.append)
    goal.send()
    result = goal.wait(20)
    assert goal.status["status"] == 3 and result == {"status": "succeeded"}
    assert any("stage" in f["status"] for f in feedback)
    here.wait_for(lambda m: m["data"] == "stage")


def test_it_aborts_navigation_to_an_unknown_location(sim, ros):
    client = action_client(ros, "navigation")
    goal = Goal(client, roslibpy.Message({"order": "navigation_go_to", "location_name": "narnia"}))
    goal.send()
    assert goal.wait(5) == {"status": "aborted"}
    assert goal.status["status"] == 4


def test_it_charges_when_docked_and_drains_faster_while_moving():
    with SimThread(**FAST, battery_soc=0.5, battery_drain_per_s=0.01, battery_charge_per_s=0.05) as sim:
        ros = roslibpy.Ros(sim.host, sim.port)
        ros.run(timeout=10)
        try:
            soc = sub(ros, "battery_soc")
            recharge = sub(ros, "battery_recharge_state")
            idle0 = state(sim)["battery"]["soc"]
            time.sleep(1.0)
            idle_drop = idle0 - state(sim)["battery"]["soc"]
            moving0 = state(sim)["battery"]["soc"]
            drive(ros, 0.0, 1.0, 0.5)
            drive(ros, 1.0, 0.0, 0.5)
            moving_drop = moving0 - state(sim)["battery"]["soc"]
            assert moving_drop > 1.5 * idle_drop > 0
            dock = sim.robot.world.locations["charging_station"]
            set_pose(ros, sim, dock.x, dock.y, dock.yaw)
            recharge.wait_for(lambda m: m["data"] > 0)
            level = state(sim)["battery"]["soc"]
            wait_until(lambda: state(sim)["battery"]["soc"] > level + 0.02)
            assert soc.items and 0.0 <= soc.items[-1]["data"] <= 1.0
        finally:
            ros.close()


# --- state machine and commander ----------------------------------------------------------------


def _changes(inbox: Inbox) -> list[tuple[str, str, str]]:
    return [(m["event"], m["from_system_state"], m["to_system_state"]) for m in inbox.items]


def test_it_goes_from_startup_to_suspension_and_publishes_the_transitions(sim, ros):
    wait_until(lambda: state(sim)["smach_state"] == "suspension", what="startup done")
    changes = sub(ros, "state_change")
    transitions = sub(ros, "state_transitions")
    pub(ros, "register_event", {"data": "restart"})
    changes.wait(lambda items: len(items) >= 2)
    assert _changes(changes)[:2] == [("restart", "suspension", "startup"), ("succeeded", "startup", "suspension")]
    offered = [json.loads(m["data"]) for m in transitions.items]
    assert {"succeeded": "suspension", "aborted": "suspension"} in offered


@pytest.mark.parametrize(("mode", "expected", "emotions_on"), [
    (ri.Mode.BEHAVIOUR, [("aborted", "suspension", "suspension"), ("behaviour_start", "suspension", "idle")], True),
    (ri.Mode.DEMO, [("aborted", "suspension", "suspension"), ("demo_start", "suspension", "demo"),
                    ("succeeded", "demo", "suspension")], False),
    (ri.Mode.MANUAL, [("aborted", "suspension", "suspension"), ("manual_start", "suspension", "manual")], False),
])
def test_it_runs_the_commander_sequence_for_a_mode(sim, ros, mode, expected, emotions_on):
    wait_until(lambda: state(sim)["smach_state"] == "suspension")
    pub(ros, "emotional_controller", {"data": "OFF" if emotions_on else "ON"})
    wait_until(lambda: state(sim)["emotion_system"] is not emotions_on)
    changes = sub(ros, "state_change")
    status = sub(ros, "emotion_system_status")
    wait_until(lambda: sim.subscription_count(ri.topic("state_change").name) == 1)
    pub(ros, "robot_mode", {"data": mode.value})
    changes.wait(lambda items: len(items) >= len(expected), timeout=5)
    assert _changes(changes)[:len(expected)] == expected
    status.wait_for(lambda m: m["data"] is emotions_on)
    assert state(sim)["mode"] == mode.value


def test_it_stops_from_behaviour_back_to_suspension(sim, ros):
    wait_until(lambda: state(sim)["smach_state"] == "suspension")
    pub(ros, "robot_mode", {"data": "behaviour"})
    wait_until(lambda: state(sim)["smach_state"] == "idle")
    changes = sub(ros, "state_change")
    wait_until(lambda: sim.subscription_count(ri.topic("state_change").name) == 1)
    pub(ros, "robot_mode", {"data": "stop"})
    changes.wait(lambda items: len(items) >= 2)
    assert _changes(changes)[:2] == [("aborted", "idle", "idle"), ("suspend", "idle", "suspension")]
    assert state(sim)["emotion_system"] is False


def test_it_ignores_an_event_the_current_state_does_not_have(sim, ros):
    wait_until(lambda: state(sim)["smach_state"] == "suspension")
    rosout = sub(ros, "rosout")
    wait_until(lambda: sim.subscription_count(ri.topic("rosout").name) == 1)
    pub(ros, "register_event", {"data": "music_play"})
    rosout.wait_for(lambda m: m["level"] == 4 and "music_play" in m["msg"])
    assert state(sim)["smach_state"] == "suspension"


def test_it_runs_timed_behaviours_and_returns_to_idle(sim, ros):
    wait_until(lambda: state(sim)["smach_state"] == "suspension")
    pub(ros, "register_event", {"data": "behaviour_start"})
    wait_until(lambda: state(sim)["smach_state"] == "idle")
    changes = sub(ros, "state_change")
    wait_until(lambda: sim.subscription_count(ri.topic("state_change").name) == 1)
    pub(ros, "register_event", {"data": "show_off_mea"})
    changes.wait(lambda items: len(items) >= 2)
    assert _changes(changes)[:2] == [("show_off_mea", "idle", "show_off_mea"), ("succeeded", "show_off_mea", "idle")]
    pub(ros, "register_event", {"data": "bedtime"})
    wait_until(lambda: state(sim)["smach_state"] == "sleeping")
    pub(ros, "register_event", {"data": "cyborg_wake_up"})
    wait_until(lambda: state(sim)["smach_state"] == "waking_up")
    wait_until(lambda: state(sim)["smach_state"] == "idle")


def test_it_runs_the_navigation_container_until_the_robot_arrives(sim, ros):
    wait_until(lambda: state(sim)["smach_state"] == "suspension")
    changes = sub(ros, "state_change")
    pub(ros, "register_event", {"data": "behaviour_start"})
    wait_until(lambda: state(sim)["smach_state"] == "idle")
    pub(ros, "register_event", {"data": "navigation_schedular"})
    wait_until(lambda: state(sim)["smach_state"] == "navigation_go_to_schedular", what="navigating")
    assert state(sim)["navigating"]
    pub(ros, "register_event", {"data": "aborted"})  # preempts the drive
    wait_until(lambda: state(sim)["smach_state"] == "idle")
    wait_until(lambda: not state(sim)["navigating"], what="navigation cancelled")
    assert ("navigation_schedular", "idle", "navigation_planning") in _changes(changes)


# --- emotions ---------------------------------------------------------------------------------


def test_it_sets_an_emotion_preset_and_answers_get_emotional_state(sim, ros):
    emotional = sub(ros, "emotional_state")
    pub(ros, "set_emotional_state", {"data": "angry"})
    msg = emotional.wait_for(lambda m: m["to_emotional_state"] == "angry")
    pad = (msg["current_pleasure"], msg["current_arousal"], msg["current_dominance"])
    assert pad == pytest.approx(ri.EMOTION_PRESETS["angry"])
    reply = call(ros, "get_emotional_state")
    assert reply["emotional_state"] == "angry"
    assert reply["current_pleasure"] == pytest.approx(-0.51)


def test_it_ignores_an_unknown_emotion_with_a_warning(sim, ros):
    rosout = sub(ros, "rosout")
    wait_until(lambda: sim.subscription_count(ri.topic("rosout").name) == 1)
    before = state(sim)["emotion"]
    pub(ros, "set_emotional_state", {"data": "sad"})
    rosout.wait_for(lambda m: m["level"] == 4 and "sad" in m["msg"])
    assert state(sim)["emotion"] == before


@pytest.mark.parametrize("switch", ["ON", "on"])
def test_it_drifts_pad_only_while_the_emotion_system_is_on(sim, ros, switch):
    pub(ros, "emotional_controller", {"data": switch})
    wait_until(lambda: state(sim)["emotion_system"] is True)
    first = state(sim)["emotion"]["pad"]
    wait_until(lambda: state(sim)["emotion"]["pad"] != first, what="drift")
    pub(ros, "emotional_controller", {"data": switch.replace("n", "ff").replace("N", "FF")})
    wait_until(lambda: state(sim)["emotion_system"] is False)
    frozen = state(sim)["emotion"]["pad"]
    time.sleep(0.3)
    assert state(sim)["emotion"]["pad"] == frozen


def test_it_nudges_pad_with_emotional_feedback(sim, ros):
    pub(ros, "set_emotional_state", {"data": "bored"})
    wait_until(lambda: state(sim)["emotion"]["name"] == "bored")
    pub(ros, "emotional_feedback", {"delta_pleasure": 0.3, "delta_arousal": 0, "delta_dominance": -0.1})
    p0, a0, d0 = ri.EMOTION_PRESETS["bored"]
    wait_until(lambda: state(sim)["emotion"]["pad"] != [p0, a0, d0])
    assert state(sim)["emotion"]["pad"] == pytest.approx([p0 + 0.3, a0, d0 - 0.1])


# --- audio and visuals ----------------------------------------------------------------------------


def test_it_queues_speech_and_reports_each_utterance_after_a_length_proportional_time(sim, ros):
    feedback = sub(ros, "tts_feedback")
    wait_until(lambda: sim.subscription_count(ri.topic("tts_feedback").name) == 1)
    long_text = "x" * 60  # 0.6 s at 0.01 s/char
    sent = time.time()
    pub(ros, "text_to_speech", {"data": long_text})
    pub(ros, "text_to_speech", {"data": "hi"})  # min 0.1 s
    feedback.wait(lambda items: len(items) >= 2, timeout=5)
    assert [m["data"] for m in feedback.items] == [long_text, "hi"]
    assert feedback.times[0] - sent >= 0.55
    assert feedback.times[1] - feedback.times[0] >= 0.09


def test_it_plays_a_clip_and_sets_the_dome_mode(sim, ros):
    played = sub(ros, "playback_feedback")
    rosout = sub(ros, "rosout")
    wait_until(lambda: sim.subscription_count(ri.topic("rosout").name) == 1)
    pub(ros, "playback", {"data": "hello_there"})
    pub(ros, "domecontrol", {"data": "rainbow"})
    played.wait_for(lambda m: m["data"] == "hello_there")
    rosout.wait_for(lambda m: m["level"] == 2 and "rainbow" in m["msg"])
    assert state(sim)["dome"] == "rainbow"
