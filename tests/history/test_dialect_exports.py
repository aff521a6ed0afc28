"""A recording of either ROS's robot exports as MCAP in the robot's own types and message layout."""

from __future__ import annotations

import asyncio
import io
import json
import time
from datetime import UTC, datetime

import pytest
from asgiref.sync import sync_to_async

from history.export import export_mcap
from history.models import Mode, Sample
from history.policies import policy_upsert
from robot import interface as ri
from tests.conftest import EITHER_ROS
from tests.helpers import async_wait_until

pytestmark = pytest.mark.django_db(transaction=True)


def _mcap(topic: str, start: float) -> list:
    from mcap.reader import make_reader

    end = time.time() + 1
    data = b"".join(export_mcap(topic, datetime.fromtimestamp(start, UTC), datetime.fromtimestamp(end, UTC)))
    return list(make_reader(io.BytesIO(data)).iter_messages())


@EITHER_ROS
async def test_the_robots_log_is_recorded_and_exported_as_the_robot_sent_it(recording, sim, link):
    await async_wait_until(lambda: link.dial.ros_version == sim.robot.ros, timeout=10, what="the link to find the ROS")
    rosout = ri.topic("rosout")
    start = time.time()
    await sync_to_async(policy_upsert)(topic=rosout.name, msg_type=rosout.type, mode=Mode.EVERY)
    await async_wait_until(lambda: rosout.name in recording.every and sim.subscription_count(rosout.name) > 0,
                           timeout=10, what="the log recorded")

    sim.call(lambda: sim.robot.bus.rosout(8, "/move_base", "planner failed"))
    kept = sync_to_async(lambda: [s for s in Sample.objects.filter(topic=rosout.name)
                                  if s.data["msg"] == "planner failed"])
    deadline = time.monotonic() + 10
    while not (samples := await kept()):
        assert time.monotonic() < deadline, "the log line was not recorded"
        await asyncio.sleep(0.1)
    sample = samples[0]
    assert sample.msg_type == rosout.type and sample.data["level"] == 8  # the model's, as the console shows it

    schema, channel, message = next(m for m in await sync_to_async(_mcap)(rosout.name, start)
                                    if json.loads(m[2].data)["msg"] == "planner failed")
    assert schema.name == rosout.type and channel.message_encoding == "json"
    exported = json.loads(message.data)
    if sim.robot.ros == ri.ROS1:
        assert schema.name == "rosgraph_msgs/Log"
        assert exported["level"] == 8 and exported["name"] == "/move_base"
        assert set(exported["header"]) == {"seq", "stamp", "frame_id"}
        assert set(exported["header"]["stamp"]) == {"secs", "nsecs"}
    else:
        assert schema.name == "rcl_interfaces/msg/Log"
        assert exported["level"] == 40 and exported["name"] == "move_base" and "header" not in exported
        assert set(exported["stamp"]) == {"sec", "nanosec"}
        assert set(json.loads(schema.data)["properties"]) == {"stamp", "level", "name", "msg", "file", "function",
                                                              "line"}


@pytest.mark.parametrize("sim", [2], indirect=True, ids=["ros2"])
async def test_a_ros2_robot_records_the_default_topics_under_its_own_names_and_types(recording, sim, link):
    """Bootstrap makes the default policies before any link knows the robot's ROS, so with ROS 1's
    names and types; once the link finds ROS 2, the recorder adds ROS 2's and takes the robot's type
    for a topic both name alike (/rosout)."""
    from history.defaults import DEFAULT_POLICIES
    from history.models import TopicPolicy

    def as_bootstrap_makes_them() -> None:
        for key, (mode, interval_s, _) in DEFAULT_POLICIES.items():
            topic = ri.topic(key, ri.ROS1)
            TopicPolicy.objects.get_or_create(topic=topic.name, defaults={"msg_type": topic.type, "mode": mode,
                                                                          "interval_s": interval_s})

    await sync_to_async(as_bootstrap_makes_them)()
    await async_wait_until(lambda: link.dial.ros_version == ri.ROS2, timeout=10, what="the link to find ROS 2")
    plan, status, rosout = (ri.topic(key, ri.ROS2) for key in ("plan", "move_base_status", "rosout"))
    await async_wait_until(lambda: {plan.name, status.name} <= recording.periodic and rosout.name in recording.every
                           and sim.subscription_count(status.name) > 0,
                           what="the recorder to take ROS 2's default topics")
    types = await sync_to_async(lambda: dict(TopicPolicy.objects.values_list("topic", "msg_type")))()
    assert types[plan.name] == "nav_msgs/msg/Path" and types[status.name] == "action_msgs/msg/GoalStatusArray"
    assert types[rosout.name] == "rcl_interfaces/msg/Log"

    sim.call(lambda: sim.robot.bus.rosout(8, "/move_base", "planner failed on ROS 2"))
    recorded = sync_to_async(lambda: Sample.objects.filter(topic=rosout.name, msg_type=rosout.type,
                                                           data__msg="planner failed on ROS 2").exists())
    deadline = time.monotonic() + 15
    while not await recorded():
        assert time.monotonic() < deadline, "the log line was not recorded with the robot's type"
        await asyncio.sleep(0.1)
