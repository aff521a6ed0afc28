import math

import pytest

from robot import interface as ri
from robot.models import AuditEntry
from tests.helpers import wait_until
from tests.navigation.conftest import EITHER_ROS, stored, wait_goal_state

# Commands audit through database_sync_to_async, which closes a PostgreSQL connection that
# sits in a test transaction: these tests need real transactions.
pytestmark = pytest.mark.django_db(transaction=True)

GOAL_TOPIC = ri.action_topic("move_base", "goal", ri.ROS1)[0]


def pose(sim) -> dict:
    return sim.snapshot()["state"]["pose"]


@EITHER_ROS
def test_it_drives_the_simulator_to_the_goal_and_reports_succeeded(nav_link, sim, operator_api):
    res = operator_api.post("/api/navigation/goal/", {"x": 1.0, "y": -2.0, "yaw": 0.0}, format="json")
    assert res.status_code == 200, res.json()
    goal = res.json()
    assert goal["status"] == "pending" and goal["by"] == "otto"
    if sim.robot.ros == ri.ROS1:  # on ROS 2 the goal travels as an action op, no topic
        sent = wait_until(lambda: sim.received(GOAL_TOPIC), what="the goal to reach the robot")[-1]
        assert sent["goal_id"]["id"] == goal["id"]
        assert sent["goal"]["target_pose"]["header"]["frame_id"] == ri.MAP_FRAME
    wait_goal_state(operator_api, "succeeded")
    p = pose(sim)
    assert math.hypot(p["x"] - 1.0, p["y"] + 2.0) < 0.25
    assert AuditEntry.objects.filter(action="navigation.goal", ok=True).count() == 1


@EITHER_ROS
def test_it_stops_the_robot_on_cancel(nav_link, sim, operator_api):
    res = operator_api.post("/api/navigation/goal/", {"x": 8.0, "y": -5.0}, format="json")
    assert res.status_code == 200, res.json()
    wait_goal_state(operator_api, "active")
    wait_until(lambda: abs(sim.snapshot()["state"]["v"]) > 0.05, what="the robot to drive")
    # The global plan the Map draws, in the map's frame, to the goal.
    plan = wait_until(lambda: (p := stored("plan")) and p["poses"] and p, what="the robot's plan")
    assert plan["header"]["frame_id"] == ri.MAP_FRAME
    end = plan["poses"][-1]["pose"]["position"]
    assert math.hypot(end["x"] - 8.0, end["y"] + 5.0) < 0.3
    if sim.robot.ros == ri.ROS2:  # Nav2's feedback: the way left, on the Map
        wait_until(lambda: "m to go" in operator_api.get("/api/navigation/status/").json()["goal"]["status_text"],
                   what="the distance left in the goal's status")
    res = operator_api.post("/api/navigation/cancel/", format="json")
    assert res.status_code == 200, res.json()
    assert res.json()["goal"]["status"] in ("cancelling", "cancelled") and res.json()["cancel_sent"] is True
    wait_goal_state(operator_api, "cancelled")
    assert operator_api.post("/api/navigation/cancel/", format="json").json()["cancel_sent"] is False
    state = wait_until(lambda: (s := sim.snapshot()["state"]) and not s["navigating"] and s, what="navigation to stop")
    assert state["goal"] is None
    wait_until(lambda: abs(sim.snapshot()["state"]["v"]) < 0.01, what="the robot to stand still")


@EITHER_ROS
def test_it_relocates_the_robot_with_an_initial_pose(nav_link, sim, operator_api):
    res = operator_api.post("/api/navigation/initial-pose/", {"x": 4.0, "y": 2.0, "yaw": math.pi}, format="json")
    assert res.status_code == 200, res.json()
    wait_until(lambda: math.hypot(pose(sim)["x"] - 4.0, pose(sim)["y"] - 2.0) < 0.05, what="the robot to move there")
    assert abs(abs(pose(sim)["yaw"]) - math.pi) < 0.05
    sent = wait_until(lambda: sim.received(ri.topic("initialpose").name), what="/initialpose")[-1]
    assert sent["header"]["frame_id"] == ri.MAP_FRAME
    cov = sent["pose"]["covariance"]
    assert cov[0] == cov[7] == 0.25 and cov[35] == pytest.approx(0.0685, abs=1e-3)
    assert sum(cov) == pytest.approx(0.5 + cov[35])


@EITHER_ROS
def test_it_lets_the_latest_goal_win(nav_link, sim, operator_api, admin_api):
    first = operator_api.post("/api/navigation/goal/", {"x": 8.0, "y": -5.0}, format="json").json()
    wait_goal_state(operator_api, "active")
    second = admin_api.post("/api/navigation/goal/", {"x": 1.0, "y": -2.0}, format="json").json()
    status = operator_api.get("/api/navigation/status/").json()
    assert status["goal"]["id"] == second["id"] != first["id"]
    assert status["goal"]["by"] == "ada"
    wait_goal_state(operator_api, "succeeded")
