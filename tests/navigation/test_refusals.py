"""Goals and poses that must never reach the robot, and who may not send them."""

import json

import pytest

from robot import interface as ri
from robot.live.groups import MAP_META_KEY
from robot.live.state import get_store
from robot.models import AuditEntry
from robot.navigation.handlers import map_meta
from robot.navigation.mapimage import map_dir, render_map
from simulator import world

# Commands audit through database_sync_to_async, which closes a PostgreSQL connection that
# sits in a test transaction: these tests need real transactions.
pytestmark = pytest.mark.django_db(transaction=True)

GOAL_TOPIC = ri.action_topic("move_base", "goal")[0]
CANCEL_TOPIC = ri.action_topic("move_base", "cancel")[0]

# glassgarden: the hall spans about -9.35..9.35 x -6.85..6.85 m; pillars at (±2, -3), (±6, 1) ...
BAD_GOALS = [
    ({"x": 25.0, "y": 0.0}, "x", "off the map"),
    ({"x": 0.0, "y": -9.0}, "y", "off the map"),
    ({"x": 2.0, "y": -3.0}, "x", "obstacle"),  # a pillar
    ({"x": -9.8, "y": 0.0}, "x", "unexplored"),  # outside the walls
    ({"x": "nan", "y": 0.0}, "x", "finite"),
    ('{"x": 0.0, "y": 1e999}', "y", "finite"),  # valid JSON that parses to infinity
    ({"x": 0.0, "y": 0.0, "yaw": "inf"}, "yaw", "finite"),
    ({"x": "two", "y": 0.0}, "x", "number"),
    ({"x": True, "y": 0.0}, "x", "number"),
    ({"y": 0.0}, "x", "required"),
]


def store_glassgarden_map() -> dict:
    """The simulator's map, rendered and announced as if the link had received it."""
    w = world.glassgarden()
    msg = {"header": {"frame_id": "map"}, "info": {
        "resolution": w.resolution, "width": w.width, "height": w.height,
        "origin": {"position": {"x": w.origin_x, "y": w.origin_y, "z": 0.0},
                   "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}, "data": w.grid.ravel().tolist()}
    meta = map_meta(render_map(msg, map_dir()), msg, 0.0)
    get_store().put(MAP_META_KEY, {"key": MAP_META_KEY, "msg": meta, "t": 0.0})
    return meta


def post_json(client, path: str, body):
    raw = body if isinstance(body, str) else json.dumps(body)
    return client.post(path, raw, content_type="application/json")


def test_it_refuses_invalid_goals_and_sends_nothing(nav_link, sim, operator_api):
    for body, field, words in BAD_GOALS:
        res = post_json(operator_api, "/api/navigation/goal/", body)
        assert res.status_code == 400, (body, res.json())
        assert res.json()["field"] == field, body
        assert words in res.json()["detail"], (body, res.json()["detail"])
        res = post_json(operator_api, "/api/navigation/initial-pose/", body)
        if words != "unexplored":  # a robot may well be localised in unexplored space
            assert res.status_code == 400, (body, res.json())
    # A valid command afterwards proves the link was working all along.
    assert operator_api.post("/api/navigation/cancel/").status_code == 200
    assert sim.received_count(GOAL_TOPIC) == 0
    assert AuditEntry.objects.filter(action="navigation.goal", ok=False, error_code="invalid").count() == len(BAD_GOALS)


def test_it_refuses_viewers(nav_link, sim, viewer_api):
    for path, body in [("/api/navigation/goal/", {"x": 1.0, "y": -2.0}), ("/api/navigation/cancel/", {}),
                       ("/api/navigation/initial-pose/", {"x": 1.0, "y": -2.0})]:
        res = viewer_api.post(path, body, format="json")
        assert res.status_code == 403, path
        assert res.json()["code"] == "forbidden"
    assert viewer_api.get("/api/navigation/status/").status_code == 200
    assert viewer_api.get("/api/map/").status_code == 200
    assert operator_api_sent_nothing(sim)
    assert AuditEntry.objects.filter(username="vera", ok=False, error_code="forbidden").count() == 3


def operator_api_sent_nothing(sim) -> bool:
    return sim.received_count(GOAL_TOPIC) == sim.received_count(CANCEL_TOPIC) == \
        sim.received_count(ri.topic("initialpose").name) == 0


def test_it_refuses_anonymous_callers(anon_api, db):
    assert anon_api.post("/api/navigation/goal/", {"x": 0, "y": 0}, format="json").status_code in (401, 403)
    assert anon_api.get("/api/map/").status_code in (401, 403)


def test_it_answers_503_when_the_robot_is_offline(operator_api):
    store_glassgarden_map()
    res = operator_api.post("/api/navigation/goal/", {"x": 1.0, "y": -2.0}, format="json")
    assert res.status_code == 503 and res.json()["code"] == "offline"
    assert operator_api.get("/api/navigation/status/").json()["goal"] is None


def test_it_answers_503_without_a_map_to_check_against(operator_api):
    res = operator_api.post("/api/navigation/goal/", {"x": 1.0, "y": -2.0}, format="json")
    assert res.status_code == 503 and res.json()["code"] == "no_map"
    assert operator_api.get("/api/map/").status_code == 404
