"""The link finds out which ROS the robot runs and gives the product the same model from either."""

from __future__ import annotations

import asyncio

import pytest

from robot import interface as ri
from robot.link.dialect import GOAL_STATUS_FROM_ROS2, goal_id_from_uuid, to_model
from tests.conftest import hosted_link
from tests.helpers import async_wait_until


@pytest.fixture(params=[ri.ROS1, ri.ROS2], ids=["ros1", "ros2"])
def ros(request):
    return request.param


@pytest.fixture
def sim_either(ros):
    from simulator.harness import SimThread

    with SimThread(port=0, video_port=0, startup_s=0.5, ros=ros) as running:
        yield running


@pytest.fixture
async def link_either(sim_either, settings):
    settings.ROBOT_ROS = "auto"
    async for hosted in hosted_link(sim_either.url, settings):
        yield hosted


async def _stored_logs():
    from robot.live.state import get_store

    return [e["msg"] for e in await get_store().aget_recent("rosout")]


@pytest.mark.django_db(transaction=True)
async def test_the_link_finds_out_the_ros_and_shows_it_in_status_and_health(link_either, ros):
    from dashboard.health import health_report
    from robot.live.state import link_status

    await async_wait_until(lambda: link_either.dial.ros_version == ros, timeout=10, what=f"the link to find ROS {ros}")
    assert ri.ros_version() == ros
    await async_wait_until(lambda: link_status().get("ros") == ros, timeout=10, what="the status to say it")
    report = await asyncio.get_running_loop().run_in_executor(None, health_report)
    assert report["ros"] == ros


async def test_finding_out_the_ros_leaves_no_error_on_a_ros1_robots_log(sim, settings):
    settings.ROBOT_ROS = "auto"
    async for hosted in hosted_link(sim.url, settings):
        await asyncio.sleep(1.0)  # the probe is asked at once on connect; its log line would follow it
        assert hosted.dial.ros_version == ri.ROS1
        assert not [m for m in await _stored_logs() if "get_ros_version" in str(m.get("msg"))]


async def test_log_lines_and_stamps_reach_the_product_in_one_model(link_either, sim_either, ros):
    from robot.live.announce import aget_state

    await async_wait_until(lambda: link_either.dial.ros_version == ros, timeout=10, what="the ROS found out")
    loop = asyncio.get_running_loop()

    async def logged() -> list[dict]:
        bus = sim_either.robot.bus
        await loop.run_in_executor(None, sim_either.call, lambda: bus.rosout(8, "/cyborg_test", "boom"))
        return [m for m in await _stored_logs() if m["msg"] == "boom"]

    deadline = loop.time() + 15
    while not (lines := await logged()):
        assert loop.time() < deadline, "the link never stored the log line"
        await asyncio.sleep(0.2)
    assert lines[-1]["level"] == 8 and lines[-1]["name"] == "/cyborg_test"
    assert lines[-1]["header"]["stamp"]["secs"] > 1_700_000_000
    odom = await _until_state(aget_state, "odom")
    assert set(odom["header"]["stamp"]) == {"secs", "nsecs"}
    assert odom["header"]["stamp"]["secs"] > 1_700_000_000


async def _until_state(aget_state, key: str) -> dict:
    loop = asyncio.get_running_loop()
    deadline = loop.time() + 10
    while not (found := (await aget_state(key)).get(key)):
        assert loop.time() < deadline, f"nothing stored for {key}"
        await asyncio.sleep(0.1)
    return found


def test_ros2_messages_become_the_ros1_model():
    log = to_model(ri.ROS2, "rcl_interfaces/msg/Log", {
        "stamp": {"sec": 5, "nanosec": 6}, "level": 30, "name": "amcl", "msg": "hi", "file": "f", "function": "g",
        "line": 3})
    assert log["level"] == 4 and log["name"] == "/amcl" and log["header"]["stamp"] == {"secs": 5, "nsecs": 6}
    cloud = to_model(ri.ROS2, "nav2_msgs/msg/ParticleCloud", {"header": {}, "particles": [
        {"pose": {"position": {"x": 1}}, "weight": 0.5}]})
    assert cloud["poses"] == [{"position": {"x": 1}}]
    uuid = list(range(16))
    status = to_model(ri.ROS2, "action_msgs/msg/GoalStatusArray", {"status_list": [
        {"goal_info": {"goal_id": {"uuid": uuid}, "stamp": {"sec": 1, "nanosec": 2}}, "status": code}
        for code in (4, 5, 6)]})
    assert [s["status"] for s in status["status_list"]] == [3, 2, 4]  # SUCCEEDED, PREEMPTED, ABORTED
    assert status["status_list"][0]["goal_id"] == {"id": bytes(uuid).hex(), "stamp": {"secs": 1, "nsecs": 2}}
    assert goal_id_from_uuid("AAECAwQFBgcICQoLDA0ODw==") == bytes(uuid).hex()
    assert GOAL_STATUS_FROM_ROS2[4] == 3
    assert to_model(ri.ROS1, "rosgraph_msgs/Log", {"level": 8}) == {"level": 8}


def test_hidden_ros2_names_are_topic_names():
    assert ri.topic_name_problem("/navigate_to_pose/_action/status") is None
    assert ri.is_hidden("/navigate_to_pose/_action/status") and not ri.is_hidden("/cmd_vel")
    assert ri.topic_name_problem("/_1x") is not None


async def test_the_link_never_publishes_on_a_hidden_name(link, sim):
    from robot.link.bus import RobotError, arequest

    name = ri.action("move_base", ri.ROS2).name + ri.ACTION_STATUS_SUFFIX
    with pytest.raises(RobotError) as refused:
        await arequest("publish", topic=name, msg_type=ri.ACTION_STATUS_TYPE, msg={"status_list": []})
    assert "hidden" in str(refused.value)
    await asyncio.sleep(0.3)
    assert not sim.received(name)


@pytest.mark.parametrize("ros", [ri.ROS2], ids=["ros2"])
async def test_a_wedged_socket_is_noticed_and_the_link_dials_again(link_either, sim_either, ros):
    from tests.sim.support import Raw

    server = Raw(sim_either.url)  # another tool serves a service that never answers
    try:
        server.send({"op": "advertise_service", "service": "/silent", "type": "std_srvs/srv/Trigger"})
        await async_wait_until(lambda: sim_either.call(lambda: "/silent" in sim_either.robot.bus.client_services),
                               timeout=10, what="the silent service")
        since = link_either.dial.since
        reply = await link_either.requests.call(ri.Service("silent", "/silent", "std_srvs/srv/Trigger"), timeout=1.0)
        assert reply["error_code"] == "timeout"
        # rosbridge 2.x now holds every later frame of the link's socket; the link notices and dials again
        await async_wait_until(lambda: link_either.connected and link_either.dial.since > since, timeout=40,
                               what="the link to reconnect")
        answer = await link_either.requests.call(ri.service("rosapi_topics"), timeout=5)
        assert answer["ok"], answer
    finally:
        server.close()
