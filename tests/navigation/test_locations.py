import math

import pytest

from robot import interface as ri
from robot.live.state import get_store
from robot.models import Location
from tests.helpers import wait_until
from tests.navigation.conftest import wait_goal_state

# Commands audit through database_sync_to_async, which closes a PostgreSQL connection that
# sits in a test transaction: these tests need real transactions.
pytestmark = pytest.mark.django_db(transaction=True)

MOVE_BASE_GOAL = ri.action_topic("move_base", "goal")[0]
NAVIGATION_GOAL = ri.action_topic("navigation", "goal")[0]


def test_it_lets_operators_create_update_list_and_delete_locations(operator_api, viewer_api):
    res = operator_api.post("/api/locations/", {"name": "lab", "x": 1.5, "y": -2.0, "yaw": 0.5,
                                                "description": "robotics lab"}, format="json")
    assert res.status_code == 201, res.json()
    assert res.json() == {"name": "lab", "map_name": "", "x": 1.5, "y": -2.0, "yaw": 0.5, "threshold": 0.5,
                          "description": "robotics lab"}
    res = operator_api.patch("/api/locations/lab/", {"threshold": 1.0, "y": -2.5}, format="json")
    assert res.status_code == 200, res.json()
    assert viewer_api.get("/api/locations/").json() == [{
        "name": "lab", "map_name": "", "x": 1.5, "y": -2.5, "yaw": 0.5, "threshold": 1.0, "description": "robotics lab",
    }]
    assert viewer_api.get("/api/locations/lab/").json()["threshold"] == 1.0
    assert operator_api.delete("/api/locations/lab/").status_code == 204
    assert not Location.objects.exists()


def test_it_refuses_location_changes_from_viewers(viewer_api):
    Location.objects.create(name="lab", x=1.0, y=2.0)
    assert viewer_api.post("/api/locations/", {"name": "x", "x": 0, "y": 0}, format="json").status_code == 403
    assert viewer_api.patch("/api/locations/lab/", {"x": 3.0}, format="json").status_code == 403
    assert viewer_api.delete("/api/locations/lab/").status_code == 403
    assert viewer_api.post("/api/locations/lab/go/").status_code == 403
    assert Location.objects.get().x == 1.0


@pytest.mark.parametrize(("body", "field"), [
    ({"name": "bad name", "x": 0, "y": 0}, "name"),
    ({"name": "a", "x": "nan", "y": 0}, "x"),
    ({"name": "a", "x": 0}, "y"),
    ({"name": "a", "x": 0, "y": 0, "threshold": -1}, "threshold"),
])
def test_it_refuses_invalid_locations(operator_api, body, field):
    res = operator_api.post("/api/locations/", body, format="json")
    assert res.status_code == 400
    assert res.json()["field"] == field


def test_it_saves_the_current_pose_under_a_name(operator_api):
    res = operator_api.post("/api/locations/", {"name": "here", "use_current_pose": True}, format="json")
    assert res.status_code == 400 and res.json()["field"] == "use_current_pose"
    pose = {"position": {"x": 1.25, "y": -3.5, "z": 0.0},
            "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(0.4), "w": math.cos(0.4)}}
    get_store().put("robot_pose", {"key": "robot_pose", "msg": pose, "t": 0.0})
    res = operator_api.post("/api/locations/", {"name": "here", "use_current_pose": True, "x": 99}, format="json")
    assert res.status_code == 201, res.json()
    saved = Location.objects.get(name="here")
    assert (saved.x, saved.y) == (1.25, -3.5) and saved.yaw == pytest.approx(0.8)


def test_it_sends_the_robot_to_a_location_with_a_move_base_goal(nav_link, sim, operator_api):
    Location.objects.create(name="lab", x=1.0, y=-2.0, yaw=math.pi / 2)
    res = operator_api.post("/api/locations/lab/go/")
    assert res.status_code == 200, res.json()
    assert res.json()["location"] == "lab" and res.json()["action"] == "move_base"
    sent = wait_until(lambda: sim.received(MOVE_BASE_GOAL), what="the goal")[-1]
    assert sent["goal"]["target_pose"]["pose"]["position"] == {"x": 1.0, "y": -2.0, "z": 0.0}
    wait_goal_state(operator_api, "succeeded")
    p = sim.snapshot()["state"]["pose"]
    assert math.hypot(p["x"] - 1.0, p["y"] + 2.0) < 0.25


def test_it_sends_the_robot_to_a_location_by_name_with_cyborg_navigation(nav_link, sim, operator_api, settings):
    settings.NAVIGATION_BACKEND = "cyborg_navigation"
    Location.objects.create(name="stage", x=6.5, y=-1.0)  # the robot knows it by name
    res = operator_api.post("/api/locations/stage/go/")
    assert res.status_code == 200, res.json()
    sent = wait_until(lambda: sim.received(NAVIGATION_GOAL), what="the navigation goal")[-1]
    assert sent["goal"] == {"order": "navigation_go_to", "location_name": "stage"}
    assert sent["goal_id"]["id"] == res.json()["id"]
    wait_goal_state(operator_api, "active")
    assert sim.received_count(MOVE_BASE_GOAL) == 0  # the robot's navigation node drives, not us
    wait_until(lambda: sim.snapshot()["state"]["navigating"], what="the robot to navigate")


def test_it_refuses_unknown_and_unreachable_locations(nav_link, sim, operator_api):
    assert operator_api.post("/api/locations/nowhere/go/").status_code == 404
    Location.objects.create(name="pillar", x=2.0, y=-3.0)
    res = operator_api.post("/api/locations/pillar/go/")
    assert res.status_code == 400 and "obstacle" in res.json()["detail"]
    assert sim.received_count(MOVE_BASE_GOAL) == 0
