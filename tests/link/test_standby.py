"""The standby's stop speaks the robot's ROS: its zero Twist has the robot's type, and the E-STOP's
cancel (named as a web process that has not heard which ROS names it) stops a running goal."""

from __future__ import annotations

import asyncio

import pytest
import roslibpy

from robot import interface as ri
from robot.link.standby import StandbyStop
from robot.navigation.goals import cancel_message
from tests.conftest import EITHER_ROS
from tests.helpers import async_wait_until
from tests.stack import free_port


@pytest.fixture
async def standby(sim, settings):
    settings.ROBOT_LINK_DIRECT_ADDRESSES = [f"127.0.0.1:{free_port()}"]
    stopper = StandbyStop(sim.url)
    task = asyncio.create_task(stopper.run())
    await async_wait_until(lambda: stopper.ros is not None and stopper.ros.is_connected, timeout=10,
                           what="the standby's connection")
    yield stopper
    task.cancel()
    await asyncio.gather(task, return_exceptions=True)


def _navigating(sim) -> bool:
    return bool(sim.snapshot()["state"]["navigating"])


@EITHER_ROS
async def test_the_standby_stops_the_robot_in_the_ros_it_speaks(sim, standby):
    await async_wait_until(lambda: standby.ros_version == sim.robot.ros, timeout=10, what="the standby to find the ROS")
    # A goal under way, sent by another tool.
    tool = roslibpy.Ros(sim.host, sim.port)
    await asyncio.to_thread(tool.run, 10)
    try:
        pose = {"header": {"frame_id": ri.MAP_FRAME}, "pose": {"position": {"x": 8.0, "y": -5.0, "z": 0.0},
                                                              "orientation": {"x": 0, "y": 0, "z": 0, "w": 1.0}}}
        goal = ri.topic("move_base_simple_goal", sim.robot.ros)
        roslibpy.Topic(tool, goal.name, goal.type).publish(roslibpy.Message(pose))
        await async_wait_until(lambda: _navigating(sim), timeout=10, what="the robot to navigate")

        assert (await standby.answer({"op": "estop"})) == {"ok": True, "standby": True}
        cmd_vel = ri.topic("cmd_vel", sim.robot.ros)
        await async_wait_until(lambda: any(ri.is_zero_twist(m) for m in sim.received(cmd_vel.name)), timeout=5,
                               what="the standby's zero Twist")
        assert standby._publishers._topics[cmd_vel.name].message_type == cmd_vel.type  # e.g. geometry_msgs/msg/Twist

        cancel, cancel_type = ri.action_topic("move_base", "cancel", ri.ROS1)
        reply = await standby.answer({"op": "publish", "topic": cancel, "msg_type": cancel_type,
                                      "msg": cancel_message(), "stopping": True, "emergency": True})
        assert reply == {"ok": True, "standby": True}
        await async_wait_until(lambda: not _navigating(sim), timeout=10, what="the goal to be cancelled")
    finally:
        await asyncio.to_thread(tool.close)
