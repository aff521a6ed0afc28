"""A goal another tool sent the robot (RViz, a script, a robot-side node) is shown as such, and the
E-STOP cancels it like any other, on either ROS."""

from __future__ import annotations

import pytest
import roslibpy

from robot import interface as ri
from robot.navigation.status import FOREIGN_GOAL_BY, GOAL_ID_PREFIX
from tests.helpers import wait_until
from tests.navigation.conftest import EITHER_ROS, wait_goal_state

pytestmark = pytest.mark.django_db(transaction=True)

TARGET = {"header": {"frame_id": ri.MAP_FRAME}, "pose": {
    "position": {"x": 8.0, "y": -5.0, "z": 0.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}


@pytest.fixture
def other_tool(sim):
    """Another client of the robot's rosbridge: unmodified roslibpy, as a script or RViz's bridge would be."""
    client = roslibpy.Ros(sim.host, sim.port)
    client.run(timeout=10)
    yield client
    client.close()


def send_goal_as_another_tool(ros: int, client: roslibpy.Ros) -> list:
    """A goal to TARGET the way a tool sends it on that ROS; on ROS 2 the list collects the action's result."""
    results: list = []
    if ros == ri.ROS1:
        name, msg_type = ri.action_topic("move_base", "goal", ri.ROS1)
        roslibpy.Topic(client, name, msg_type).publish(roslibpy.Message(
            {"header": {"frame_id": ri.MAP_FRAME}, "goal_id": {"stamp": {"secs": 0, "nsecs": 0}, "id": "rviz-goal-1"},
             "goal": {"target_pose": TARGET}}))
    else:
        nav = ri.action("move_base", ri.ROS2)
        roslibpy.ActionClient(client, nav.name, nav.type).send_goal(
            roslibpy.Goal({"pose": TARGET, "behavior_tree": ""}), results.append, lambda feedback: None, results.append)
    return results


def foreign_goal(api) -> dict | None:
    goal = api.get("/api/navigation/status/").json()["goal"]
    return goal if goal and goal["foreign"] else None


@EITHER_ROS
def test_a_goal_another_tool_sent_is_shown_as_such_and_the_estop_cancels_it(nav_link, sim, other_tool, operator_api):
    results = send_goal_as_another_tool(sim.robot.ros, other_tool)
    goal = wait_until(lambda: (g := foreign_goal(operator_api)) and g["status"] == "active" and g,
                      what="the other tool's goal, under way, in the navigation status")
    assert goal["by"] == FOREIGN_GOAL_BY and not goal["id"].startswith(GOAL_ID_PREFIX)
    assert goal["x"] is None and goal["finished"] is False
    wait_until(lambda: sim.snapshot()["state"]["navigating"], what="the robot to navigate")

    body = operator_api.post("/api/robot/estop/").json()
    assert next(s for s in body["steps"] if s["step"] == "cancel_navigation")["ok"], body["steps"]
    assert wait_goal_state(operator_api, "cancelled") == "cancelled"
    assert foreign_goal(operator_api)["id"] == goal["id"]
    wait_until(lambda: not sim.snapshot()["state"]["navigating"], what="the robot to stop navigating")
    if sim.robot.ros == ri.ROS2:  # the tool that sent it hears CANCELED (5)
        done = wait_until(lambda: results and results[0], what="the other tool's result")
        assert done["status"] == roslibpy.core.GoalStatus.CANCELED


@EITHER_ROS
def test_the_latest_goal_wins_whoever_sent_it(nav_link, sim, other_tool, operator_api):
    send_goal_as_another_tool(sim.robot.ros, other_tool)
    wait_until(lambda: (g := foreign_goal(operator_api)) and g["status"] == "active", what="the other tool's goal")
    ours = operator_api.post("/api/navigation/goal/", {"x": 1.0, "y": -2.0}, format="json").json()
    wait_until(lambda: (g := operator_api.get("/api/navigation/status/").json()["goal"])["id"] == ours["id"]
               and g["status"] == "active" and not g["foreign"], what="our goal as the current one")
    # The other tool's goal was preempted by ours, and the robot drives to ours.
    assert wait_goal_state(operator_api, "succeeded") == "succeeded"
