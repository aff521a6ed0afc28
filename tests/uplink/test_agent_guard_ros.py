"""The agent's own stop publishes the drive topic as the robot spells its type, on either ROS."""

from __future__ import annotations

import asyncio

import pytest

from simulator.harness import SimThread
from tests.helpers import async_wait_until
from uplink_agent.safety import LocalGuard


@pytest.mark.parametrize(("ros", "spelling"), [(1, "geometry_msgs/Twist"), (2, "geometry_msgs/msg/Twist")])
async def test_the_local_guard_stops_the_robot_with_its_own_type(ros, spelling):
    with SimThread(startup_s=0.3, ros=ros) as sim:
        guard = LocalGuard(sim.url, "/cmd_vel")
        task = asyncio.get_running_loop().create_task(guard.run())
        try:
            await async_wait_until(lambda: guard.socket is not None, timeout=10, what="the safety session")
            assert guard.twist_type == spelling
            assert guard.publish_zero()
            await async_wait_until(lambda: sim.received("/cmd_vel"), timeout=10, what="the zero Twist")
            assert sim.received("/cmd_vel")[-1]["linear"]["x"] == 0.0
        finally:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
