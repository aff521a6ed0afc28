"""The front door works the same when the robot dials out: the product (Daphne with the link inside)
reaches the simulator only through the uplink agent, and unmodified roslibpy tools watch and drive
through the front door, velocity under the drive lock and its deadman."""

from __future__ import annotations

import time

import roslibpy

from robot import interface as ri
from tests.frontdoor.conftest import post, received, ros_for
from tests.helpers import wait_until
from tests.sim.support import Inbox
from tests.stack import PASSWORD, Stack, free_port
from tests.uplink.support import Agent

ODOM, CMD_VEL = ri.topic("odom").name, ri.topic("cmd_vel").name
FORWARD = {"linear": {"x": 0.3, "y": 0, "z": 0}, "angular": {"x": 0, "y": 0, "z": 0}}


def test_tools_watch_and_drive_through_the_front_door_while_the_robot_dials_out():
    uplink, relay, video_relay = free_port(), free_port(), free_port()
    stack = Stack(env={"UPLINK": "true", "UPLINK_LISTEN": f"127.0.0.1:{uplink}", "UPLINK_ROSBRIDGE_PORT": str(relay),
                       "UPLINK_VIDEO_PORT": str(video_relay), "ROSBRIDGE_URL": f"ws://127.0.0.1:{relay}",
                       "VIDEO_URL": f"http://127.0.0.1:{video_relay}", "TELEOP_DEADMAN_S": "0.5"})
    with stack:
        code = "from robot.uplink.credentials import credential_create\nprint(credential_create(robot='cyborg')[1])"
        credential = stack.manage("shell", "-c", code).strip().splitlines()[-1]
        with Agent(server_url=f"ws://127.0.0.1:{uplink}/uplink/", credential=credential,
                   rosbridge_url=f"ws://127.0.0.1:{stack.sim_port}",
                   video_url=f"http://127.0.0.1:{stack.video_port}") as agent:
            try:
                stack.wait_robot_online(timeout=60)
            except RuntimeError as exc:
                raise AssertionError(f"{exc}\nagent:\n{agent.log()[-3000:]}") from None
            stack.tokens = {name: post(stack, "/api/auth/token/", data={"username": name, "password": PASSWORD})
                            ["token"] for name in ("otto", "vera")}
            viewer, operator = ros_for(stack, "vera"), ros_for(stack, "otto")
            try:
                odom = Inbox()
                roslibpy.Topic(viewer, ODOM, "nav_msgs/Odometry").subscribe(odom)
                odom.wait(lambda items: len(items) >= 3, timeout=30, what="odometry through the uplink")
                assert {"header", "pose", "twist"} <= set(odom.items[-1])
                cmd = roslibpy.Topic(operator, CMD_VEL, "geometry_msgs/Twist")
                cmd.advertise()
                for _ in range(10):
                    cmd.publish(roslibpy.Message(FORWARD))
                    time.sleep(0.1)
                wait_until(lambda: any(m["msg"]["linear"]["x"] > 0.2 for m in received(stack, CMD_VEL)),
                           timeout=20, what="the robot commanded forward through the uplink")
                # The tool stops sending: the deadman's zero reaches the robot the same way.
                wait_until(lambda: received(stack, CMD_VEL)[-1]["msg"]["linear"]["x"] == 0.0, timeout=20,
                           what="the deadman's zero")
            finally:
                viewer.close()
                operator.close()
