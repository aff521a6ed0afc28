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
    await async_wait_until(lambda: link.ros_version == sim.robot.ros, timeout=10, what="the link to find the ROS")
    rosout = ri.topic("rosout")
    start = time.time()
    await sync_to_async(policy_upsert)(topic=rosout.name, msg_type=rosout.type, mode=Mode.EVERY)
    await async_wait_until(lambda: rosout.name in recording.every and sim.subscription_count(rosout.name) > 0,
                           timeout=10, what="the log recorded")

    sim.call(lambda: sim.robot.rosout(8, "/move_base", "planner failed"))
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
