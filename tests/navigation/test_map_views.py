import io
import json
import re

import pytest
from PIL import Image

from tests.navigation.test_refusals import store_glassgarden_map


def test_it_serves_the_map_metadata_and_its_cached_image(nav_link, sim, client, viewer):
    client.force_login(viewer)
    meta = client.get("/api/map/").json()
    expected = sim.snapshot()["map"]
    assert (meta["width"], meta["height"], meta["resolution"]) == (expected["width"], expected["height"],
                                                                    expected["resolution"])
    assert [meta["origin"]["x"], meta["origin"]["y"]] == expected["origin"]
    assert meta["image_url"] == f"/map/image/{meta['version']}.png"
    res = client.get(meta["image_url"])
    assert res.status_code == 200 and res["Content-Type"] == "image/png"
    assert res["Cache-Control"] == "public, max-age=31536000, immutable"
    assert res["ETag"] == f'"{meta["version"]}"'
    image = Image.open(io.BytesIO(b"".join(res.streaming_content)))
    assert image.size == (meta["width"], meta["height"])
    assert client.get(meta["image_url"], HTTP_IF_NONE_MATCH=res["ETag"]).status_code == 304


@pytest.mark.django_db
def test_it_answers_404_for_unknown_map_versions(client, viewer):
    client.force_login(viewer)
    assert client.get("/map/image/0123456789abcdef0123.png").status_code == 404
    assert client.get("/map/image/..%2Fsecret_key.png").status_code == 404


@pytest.mark.django_db
def test_it_keeps_the_map_image_behind_the_login(client):
    meta = store_glassgarden_map()
    res = client.get(meta["image_url"])
    assert res.status_code == 302 and "/accounts/login/" in res["Location"]


def page_config(html: str) -> dict:
    match = re.search(r'<script id="map-config" type="application/json">(.*?)</script>', html, re.S)
    return json.loads(match.group(1))


@pytest.mark.django_db
def test_it_renders_the_map_page_with_disabled_controls_for_viewers(client, viewer):
    meta = store_glassgarden_map()
    client.force_login(viewer)
    html = client.get("/map/").content.decode()
    config = page_config(html)
    assert config["map"]["version"] == meta["version"]
    assert {"robot_pose", "plan", "nav_goal", "nav_goal_status", "map_meta"} <= set(config["keys"])
    assert re.search(r'data-mode="goal" disabled', html)
    assert re.search(r'id="goal-cancel" disabled', html)
    assert 'data-can-command="0"' in html


@pytest.mark.django_db
def test_it_renders_the_map_page_with_controls_for_operators(client, operator):
    client.force_login(operator)
    html = client.get("/map/").content.decode()
    assert page_config(html)["map"] is None
    assert 'data-can-command="1"' in html
    assert not re.search(r'data-mode="goal" disabled', html)
