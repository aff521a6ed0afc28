"""Goals while the motors are off (an E-STOP release leaves them off): refused at once with that
reason in the API's one error shape, never accepted to abort later; none reaches the robot."""

import pytest

from robot import interface as ri
from robot.models import AuditEntry, Location
from tests.helpers import wait_until
from tests.navigation.conftest import _private_var_dir, nav_link, sim, stored  # noqa: F401  (the map and its link)

pytestmark = pytest.mark.django_db(transaction=True)

GOAL_TOPIC = ri.action_topic("move_base", "goal")[0]


def motors(client, on: bool) -> None:
    """Switch the motors with the product's own command; wait until the robot says so."""
    res = client.post("/api/robot/motors/", {"enabled": on}, format="json")
    assert res.status_code == 200, res.json()
    wait_until(lambda: (stored("motors_state") or {}).get("data") is on, timeout=10, what=f"motors {on}")


def refused_for_motors(res) -> None:
    assert res.status_code == 409, res.json()
    body = res.json()
    assert body["code"] == "motors_off" and body["detail"].startswith("Motors off"), body
    assert set(body) == {"detail", "code"}


def test_a_goal_is_refused_while_the_motors_are_off(nav_link, sim, operator_api):  # noqa: F811
    motors(operator_api, False)
    refused_for_motors(operator_api.post("/api/navigation/goal/", {"x": 1.0, "y": -2.0}, format="json"))
    Location.objects.create(name="lab", x=1.0, y=-2.0, yaw=0.0)
    refused_for_motors(operator_api.post("/api/locations/lab/go/"))
    assert sim.received(GOAL_TOPIC) == []
    assert operator_api.get("/api/navigation/status/").json()["goal"] is None
    assert AuditEntry.objects.filter(action__in=["navigation.goal", "navigation.go_to"], ok=False,
                                     error_code="motors_off").count() == 2
    motors(operator_api, True)
    res = operator_api.post("/api/navigation/goal/", {"x": 1.0, "y": -2.0}, format="json")
    assert res.status_code == 200, res.json()
    wait_until(lambda: sim.received(GOAL_TOPIC), what="the goal to reach the robot")


def test_a_goal_by_name_to_the_robots_navigation_is_refused_too(nav_link, sim, operator_api, settings):  # noqa: F811
    settings.NAVIGATION_BACKEND = "cyborg_navigation"
    motors(operator_api, False)
    Location.objects.create(name="stage", x=1.0, y=-2.0, yaw=0.0)
    refused_for_motors(operator_api.post("/api/locations/stage/go/"))
    assert sim.received(ri.action_topic("navigation", "goal")[0]) == []
