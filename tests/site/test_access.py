"""Every page, API endpoint and websocket requires login."""

import pytest

from tests.helpers import ws_communicator


@pytest.mark.parametrize("path", ["/", "/map/", "/drive/", "/topics/", "/statemachine/", "/diagnostics/",
                                  "/history/", "/activity/"])
def test_it_redirects_anonymous_pages_to_login(client, db, path):
    response = client.get(path)
    assert response.status_code == 302
    assert response["Location"].startswith("/accounts/login/")


def test_it_refuses_anonymous_api_calls(anon_api, db):
    response = anon_api.get("/api/robot/state/")
    assert response.status_code in (401, 403)


async def test_it_refuses_anonymous_websockets():
    from django.contrib.auth.models import AnonymousUser

    communicator = ws_communicator(AnonymousUser())
    connected, _ = await communicator.connect()
    assert connected is False


async def test_it_refuses_websockets_from_foreign_origins(viewer):
    from channels.testing import WebsocketCommunicator

    from server.asgi import application

    communicator = WebsocketCommunicator(application, "/ws/live/", headers=[(b"origin", b"http://evil.example")])
    communicator.scope["user"] = viewer
    connected, _ = await communicator.connect()
    assert connected is False


def test_it_renders_the_dashboard_for_a_viewer_without_command_controls(client, viewer):
    client.force_login(viewer)
    response = client.get("/")
    assert response.status_code == 200
    body = response.content.decode()
    assert 'data-field="battery.percent"' in body
    assert 'id="reconnect-btn"' not in body


def test_it_offers_reconnect_to_operators(client, operator):
    client.force_login(operator)
    assert 'id="reconnect-btn"' in client.get("/").content.decode()


def test_it_logs_in_with_the_form(client, operator):
    from django.test import Client

    from tests.conftest import PASSWORD

    response = client.post("/accounts/login/", {"username": "otto", "password": PASSWORD})
    assert response.status_code == 302 and response["Location"] == "/"
    bad = Client().post("/accounts/login/", {"username": "otto", "password": "nope"})
    assert b"Wrong username or password" in bad.content


def test_it_reports_health_without_login(client, db):
    response = client.get("/healthz")
    assert response.status_code == 200
    assert response.json()["connected"] is False
