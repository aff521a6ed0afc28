"""Each person's overlay choices are kept on the server, checked, and shown on their map page."""

import json

import pytest

from robot.overlays.costmap import Costmap, costmap_dir

pytestmark = pytest.mark.django_db

URL = "/api/me/map-overlays/"


def test_overlays_start_off_and_each_person_keeps_their_own(viewer_api, operator_api):
    assert set(viewer_api.get(URL).json().values()) == {False}
    answer = viewer_api.patch(URL, {"scan": True, "global_costmap": True}, format="json")
    assert answer.status_code == 200
    assert answer.json()["scan"] is True and answer.json()["particles"] is False
    assert viewer_api.patch(URL, {"global_costmap": False}, format="json").json()["scan"] is True
    assert viewer_api.get(URL).json() == {**dict.fromkeys(answer.json(), False), "scan": True}
    assert operator_api.get(URL).json()["scan"] is False


@pytest.mark.parametrize("body, field", [({"lidar": True}, "lidar"), ({"scan": "yes"}, "scan"),
                                         ({"scan": 1}, "scan")])
def test_unknown_overlays_and_non_booleans_are_refused(viewer_api, body, field):
    answer = viewer_api.patch(URL, body, format="json")
    assert answer.status_code == 400
    assert answer.json()["field"] == field
    assert viewer_api.get(URL).json()["scan"] is False


def test_the_api_needs_a_signed_in_person(anon_api):
    assert anon_api.get(URL).status_code in (401, 403)


def test_the_map_page_starts_with_the_persons_overlays(client, viewer, viewer_api):
    viewer_api.patch(URL, {"particles": True}, format="json")
    client.force_login(viewer)
    page = client.get("/map/")
    html = page.content.decode()
    config = json.loads(html.split('id="map-config" type="application/json">')[1].split("</script>")[0])
    assert config["overlays"]["particles"] is True and config["overlays"]["scan"] is False
    assert config["urls"]["overlays"] == URL


def test_costmap_tiles_are_served_immutable_and_nothing_else_is(client, viewer, settings, tmp_path):
    settings.VAR_DIR = tmp_path
    costmap = Costmap("global", costmap_dir())
    costmap.load({"header": {}, "info": {"resolution": 0.05, "width": 2, "height": 2, "origin": {
        "position": {"x": 0, "y": 0, "z": 0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}},
        "data": [0, 100, 50, -1]}, "map")
    client.force_login(viewer)
    url = f"/map/costmap/global/{costmap.version}/0-0-0.png"
    answer = client.get(url)
    assert answer.status_code == 200 and answer["Content-Type"] == "image/png"
    assert "immutable" in answer["Cache-Control"]
    assert client.get(url, HTTP_IF_NONE_MATCH=answer["ETag"]).status_code == 304
    for bad in (f"/map/costmap/other/{costmap.version}/0-0-0.png", "/map/costmap/global/zz/0-0-0.png",
                f"/map/costmap/global/{costmap.version}/0-0-9.png", f"/map/costmap/global/{costmap.version}/x.png"):
        assert client.get(bad).status_code == 404, bad
    client.logout()
    assert client.get(url).status_code in (302, 401, 403)
