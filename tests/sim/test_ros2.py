"""``python -m simulator --ros 2`` behaves like the ROS 2 Jazzy rosbridge 2.x with Nav2 (ROBOT_INTERFACE.md,
"ROS 2 robots"), as unmodified roslibpy and a bare websocket client see it."""

from __future__ import annotations

import base64
from collections.abc import Iterator

import pytest
import roslibpy

from robot import interface as ri
from simulator.harness import SimThread
from tests.sim.support import FAST, Inbox, Raw, on_topic, subscribe, wait_until

ROS2 = ri.ROS2
NAV = ri.action("move_base", ROS2)
ZERO_GOAL_INFO = {"goal_id": {"uuid": [0] * 16}, "stamp": {"sec": 0, "nanosec": 0}}


@pytest.fixture
def sim2(request: pytest.FixtureRequest) -> Iterator[SimThread]:
    kwargs = getattr(request, "param", {})
    with SimThread(**FAST, ros=2, **kwargs) as running:
        yield running


@pytest.fixture
def ros2(sim2: SimThread) -> Iterator[roslibpy.Ros]:
    client = roslibpy.Ros(sim2.host, sim2.port)
    client.run(timeout=10)
    yield client
    client.close()


@pytest.fixture
def raw2(sim2: SimThread) -> Iterator[Raw]:
    raw = Raw(sim2.url)
    yield raw
    raw.close()


def _goal(x: float, y: float) -> roslibpy.Goal:
    return roslibpy.Goal({"pose": {"header": {"frame_id": "map"}, "pose": {
        "position": {"x": x, "y": y, "z": 0.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}},
        "behavior_tree": ""})


def _send(ros: roslibpy.Ros, x: float, y: float) -> tuple[str, Inbox, Inbox]:
    client = roslibpy.ActionClient(ros, NAV.name, NAV.type)
    feedback, result = Inbox(), Inbox()
    goal_id = client.send_goal(_goal(x, y), result, feedback, result)
    return goal_id, feedback, result


def _a_free_point_away(sim: SimThread) -> tuple[float, float]:
    def pick() -> tuple[float, float]:
        nav, body = sim.robot.nav_node, sim.robot.base
        while True:
            x, y = nav.random_free_point()
            if (x - body.x) ** 2 + (y - body.y) ** 2 > 4.0 and nav.planner.plan((body.x, body.y), (x, y)):
                return x, y
    return sim.call(pick)


def test_type_names_go_out_in_three_parts_and_both_spellings_come_in(sim2, ros2, raw2):
    topics = raw2.call("/rosapi/topics")["values"]
    types = dict(zip(topics["topics"], topics["types"], strict=True))
    assert types["/cmd_vel"] == "geometry_msgs/msg/Twist"
    assert types["/rosout"] == "rcl_interfaces/msg/Log"
    assert types[NAV.name + ri.ACTION_STATUS_SUFFIX] == "action_msgs/msg/GoalStatusArray"
    assert raw2.call("/rosapi/topic_type", {"topic": "/odom"})["values"]["type"] == "nav_msgs/msg/Odometry"
    assert raw2.call("/rosapi/service_type", {"service": "/rosapi/topics"})["values"]["type"] == \
        "rosapi_msgs/srv/Topics"
    # topics_for_type does not normalise: asked in two parts it finds nothing
    assert raw2.call("/rosapi/topics_for_type", {"type": "geometry_msgs/Twist"})["values"]["topics"] == []
    assert "/cmd_vel" in raw2.call("/rosapi/topics_for_type", {"type": "geometry_msgs/msg/Twist"})["values"]["topics"]
    # either spelling subscribes and publishes
    old = subscribe(ros2, "/odom", "nav_msgs/Odometry")
    new = subscribe(ros2, "/robot_pose", "geometry_msgs/msg/Pose")
    old.wait(what="odometry")
    new.wait(what="a pose")
    roslibpy.Topic(ros2, "/cmd_vel", "geometry_msgs/Twist").publish(
        roslibpy.Message({"linear": {"x": 0.1, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}))
    wait_until(lambda: sim2.received("/cmd_vel"))


def test_raw_types_are_ros_2_definitions_as_roslibpy_reads_them(ros2):
    service = roslibpy.Service(ros2, "/rosapi/topics_and_raw_types", "rosapi_msgs/srv/TopicsAndRawTypes")
    values = service.call(roslibpy.ServiceRequest(), timeout=10)
    by_topic = dict(zip(values["topics"], zip(values["types"], values["typedefs_full_text"], strict=True),
                        strict=True))
    log_type, log_text = by_topic["/rosout"]
    assert log_type == "rcl_interfaces/msg/Log" and "rosgraph_msgs/Log" not in values["types"]
    assert log_text.startswith("uint8 DEBUG=10\n") and "builtin_interfaces/Time stamp" in log_text
    odom_type, odom_text = by_topic["/odom"]
    assert odom_type == "nav_msgs/msg/Odometry"
    assert "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n" in odom_text  # no seq
    assert "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n" in odom_text


def test_stamps_are_sec_and_nanosec_headers_have_no_seq_and_both_spellings_come_in(sim2, ros2):
    odom = subscribe(ros2, "/odom", "nav_msgs/msg/Odometry").wait_for(lambda m: True, what="odometry")
    assert set(odom["header"]) == {"stamp", "frame_id"}
    assert set(odom["header"]["stamp"]) == {"sec", "nanosec"} and odom["header"]["stamp"]["sec"] > 1_700_000_000
    initial = roslibpy.Topic(ros2, "/initialpose", "geometry_msgs/msg/PoseWithCovarianceStamped")
    for stamp in ({"sec": 12, "nanosec": 34}, {"secs": 56, "nsecs": 78}):
        initial.publish(roslibpy.Message({"header": {"stamp": stamp, "frame_id": "map"},
                                          "pose": {"pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.0},
                                                            "orientation": {"w": 1.0}}}}))
    wait_until(lambda: len(sim2.received("/initialpose")) == 2)
    assert [m["header"]["stamp"] for m in sim2.received("/initialpose")] == [
        {"secs": 12, "nsecs": 34}, {"secs": 56, "nsecs": 78}]


def test_rosout_is_rcl_interfaces_log_with_levels_10_to_50(sim2, ros2, raw2):
    raw2.send({"op": "subscribe", "id": "old", "topic": "/rosout", "type": "rosgraph_msgs/Log"})
    logs = subscribe(ros2, "/rosout", "rcl_interfaces/msg/Log")
    wait_until(lambda: sim2.subscription_count("/rosout") == 1)
    sim2.call(lambda: [sim2.robot.bus.rosout(level, "/tester", f"level {level}") for level in (1, 2, 4, 8, 16)])
    got = logs.wait(lambda items: [m for m in items if m["name"] == "tester"] if len(
        [m for m in items if m["name"] == "tester"]) == 5 else None, what="five log lines")
    assert [m["level"] for m in got] == [10, 20, 30, 40, 50]
    assert set(got[0]) == {"stamp", "level", "name", "msg", "file", "function", "line"}
    # the ROS 1 type does not exist there: that subscriber hears nothing
    assert not raw2.collect(0.5, on_topic("/rosout"))


def test_ros_version_is_served_on_ros_2_only(sim2, raw2):
    assert raw2.call("/rosapi/get_ros_version")["values"] == {"version": 2, "distro": "jazzy"}
    with SimThread(**FAST) as ros1:
        raw = Raw(ros1.url)
        try:
            reply = raw.call("/rosapi/get_ros_version")
        finally:
            raw.close()
    assert reply["result"] is False
    assert reply["values"] == "Service /rosapi/get_ros_version does not exist"


def test_a_nav2_goal_reports_feedback_and_succeeds_with_status_4(sim2, ros2):
    x, y = _a_free_point_away(sim2)
    _, feedback, result = _send(ros2, x, y)
    first = feedback.wait_for(lambda m: True, what="feedback")
    assert set(first) == {"current_pose", "navigation_time", "estimated_time_remaining", "number_of_recoveries",
                          "distance_remaining"}
    assert first["distance_remaining"] > 0.5
    assert set(first["estimated_time_remaining"]) == {"sec", "nanosec"}
    done = result.wait_for(lambda m: True, timeout=60, what="the result")
    assert done["status"] == roslibpy.core.GoalStatus.SUCCEEDED  # 4: actionlib's 4 meant ABORTED
    assert done["values"] == {"error_code": 0, "error_msg": ""}


def test_a_cancel_on_the_goals_own_socket_is_ignored_by_default(sim2, ros2):
    x, y = _a_free_point_away(sim2)
    goal_id, feedback, result = _send(ros2, x, y)
    feedback.wait(what="feedback")
    roslibpy.ActionClient(ros2, NAV.name, NAV.type).cancel_goal(goal_id)
    done = result.wait_for(lambda m: True, timeout=60, what="the result")
    assert done["status"] == roslibpy.core.GoalStatus.SUCCEEDED


@pytest.mark.parametrize("sim2", [{"goals_in_new_thread": True}], indirect=True)
def test_with_goals_in_new_threads_a_cancel_on_the_same_socket_cancels(sim2, ros2):
    x, y = _a_free_point_away(sim2)
    goal_id, feedback, result = _send(ros2, x, y)
    feedback.wait(what="feedback")
    roslibpy.ActionClient(ros2, NAV.name, NAV.type).cancel_goal(goal_id)
    assert result.wait_for(lambda m: True, timeout=10, what="the result")["status"] == roslibpy.core.GoalStatus.CANCELED


def test_the_hidden_cancel_service_with_a_zero_uuid_cancels_every_goal_and_status_shows_it(sim2, ros2, raw2):
    status_name = NAV.name + ri.ACTION_STATUS_SUFFIX
    statuses = subscribe(ros2, status_name, "action_msgs/msg/GoalStatusArray")
    x, y = _a_free_point_away(sim2)
    _, feedback, result = _send(ros2, x, y)
    feedback.wait(what="feedback")
    executing = statuses.wait_for(lambda m: any(s["status"] == 2 for s in m["status_list"]), what="EXECUTING")
    uuid = executing["status_list"][-1]["goal_info"]["goal_id"]["uuid"]
    assert len(base64.b64decode(uuid)) == 16
    reply = raw2.call(NAV.name + ri.ACTION_CANCEL_SUFFIX, {"goal_info": ZERO_GOAL_INFO})
    assert reply["result"] is True and reply["values"]["return_code"] == 0
    assert [g["goal_id"]["uuid"] for g in reply["values"]["goals_canceling"]] == [uuid]
    assert result.wait_for(lambda m: True, timeout=10, what="the result")["status"] == roslibpy.core.GoalStatus.CANCELED
    statuses.wait_for(lambda m: {"goal_info": executing["status_list"][-1]["goal_info"], "status": 5}
                      in m["status_list"], what="CANCELED in the status")
    assert not sim2.snapshot()["state"]["navigating"]
    again = raw2.call(NAV.name + ri.ACTION_CANCEL_SUFFIX, {"goal_info": ZERO_GOAL_INFO}, cid="c2")
    assert again["values"]["return_code"] == 1  # nothing left to cancel


def test_particles_are_a_nav2_particle_cloud(sim2, ros2):
    cloud = subscribe(ros2, "/particle_cloud", "nav2_msgs/msg/ParticleCloud").wait_for(lambda m: True, what="particles")
    assert cloud["particles"] and set(cloud["particles"][0]) == {"pose", "weight"}
    assert "poses" not in cloud


def _advertise_silent_service(sim: SimThread) -> Raw:
    server = Raw(sim.url)
    server.send({"op": "advertise_service", "service": "/silent", "type": "std_srvs/srv/Trigger"})
    wait_until(lambda: sim.call(lambda: "/silent" in sim.robot.bus.client_services))
    return server


def test_a_call_that_is_never_answered_wedges_that_client_only(sim2, raw2):
    server = _advertise_silent_service(sim2)
    other = Raw(sim2.url)
    try:
        raw2.send({"op": "call_service", "service": "/silent", "id": "never"})
        server.expect(lambda f: f.get("op") == "call_service")
        with pytest.raises(AssertionError):
            raw2.call("/rosapi/get_time", cid="after", timeout=1.0)
        assert other.call("/rosapi/get_time")["result"] is True
    finally:
        server.close()
        other.close()


@pytest.mark.parametrize("sim2", [{"services_in_new_thread": True}], indirect=True)
def test_with_services_in_new_threads_an_unanswered_call_wedges_nothing(sim2, raw2):
    server = _advertise_silent_service(sim2)
    try:
        raw2.send({"op": "call_service", "service": "/silent", "id": "never"})
        server.expect(lambda f: f.get("op") == "call_service")
        assert raw2.call("/rosapi/get_time", cid="after")["result"] is True
    finally:
        server.close()


def test_get_param_names_crashes_rosapi(sim2, raw2):
    raw2.send({"op": "call_service", "service": "/rosapi/get_param_names", "id": "crash"})
    wait_until(lambda: sim2.call(lambda: "/rosapi/topics" not in sim2.robot.bus.services))
    other = Raw(sim2.url)
    try:
        assert other.call("/rosapi/topics")["values"] == "Service /rosapi/topics does not exist"
    finally:
        other.close()
    assert not raw2.collect(0.3, lambda f: f.get("id") == "crash")
