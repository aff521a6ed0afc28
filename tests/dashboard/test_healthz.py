"""/healthz: anyone gets each check up or down and nothing more; a logged-in staff member or an
admin's API token also gets the robot's and the video server's addresses and the error texts."""

from __future__ import annotations

import json

import pytest
from django.db import OperationalError
from django.test import Client

from dashboard import health
from robot.api.tokens import token_for

pytestmark = pytest.mark.django_db

PUBLIC = {"ok", "down", "checks", "connected", "link_running", "command_path"}
SECRET = "10.20.30.40:5432"  # an address a failing check's error text names


@pytest.fixture
def failing_check(monkeypatch):
    monkeypatch.setattr(health, "CHECKS", [*health.CHECKS, lambda: health.Check("camera", False, f"no {SECRET}")])


def get(client: Client, **headers: str):
    response = client.get("/healthz", headers=headers)
    return response.status_code, response.json(), response.content.decode()


def test_it_tells_anyone_only_what_is_up_and_what_is_down(client, settings, failing_check):
    status, body, text = get(client)
    assert status == 503
    assert set(body) == PUBLIC | {"detail", "code"}, body
    assert body["down"] == ["camera"] and body["checks"]["camera"] == {"ok": False}
    assert body["checks"]["database"] == {"ok": True}
    assert body["detail"] == "service unavailable: camera" and body["code"] == "unavailable"
    for secret in (SECRET, settings.ROSBRIDGE_URL, settings.VIDEO_URL, "127.0.0.1"):
        assert secret not in text


@pytest.mark.parametrize("user", ["viewer", "operator"])
def test_it_tells_people_who_are_not_staff_no_more_than_anyone(client, request, settings, user):
    client.force_login(request.getfixturevalue(user))
    status, body, _ = get(client)
    assert status == 200 and set(body) == PUBLIC, body
    api_status, api_body, _ = get(Client(), authorization=f"Token {token_for(request.getfixturevalue(user)).key}")
    assert (api_status, set(api_body)) == (200, PUBLIC)


def test_it_gives_a_logged_in_staff_member_the_addresses_and_error_texts(client, admin_user, settings, failing_check):
    client.force_login(admin_user)
    status, body, _ = get(client)
    assert status == 503
    assert body["robot_url"] == settings.ROSBRIDGE_URL and body["video_url"] == settings.VIDEO_URL
    assert body["checks"]["camera"] == {"ok": False, "detail": f"no {SECRET}"}
    assert {"failing_tasks", "link_holder", "failed_subscriptions", "history_lost_in_handovers"} <= set(body)
    # Redis is checked in both wirings; embedded, it is the process's private server.
    assert body["checks"]["redis"] == ({"ok": True, "detail": "embedded: this process's private server"}
                                       if settings.EMBEDDED else {"ok": True})


def test_it_gives_an_admins_token_the_details_and_a_wrong_token_what_anyone_gets(admin_user, settings):
    status, body, _ = get(Client(), authorization=f"Token {token_for(admin_user).key}")
    assert status == 200 and body["robot_url"] == settings.ROSBRIDGE_URL
    status, body, _ = get(Client(), authorization="Token not-a-token")
    assert status == 200 and set(body) == PUBLIC


def test_it_is_never_cached(client):
    assert "no-store" in client.get("/healthz")["Cache-Control"]


def test_a_staff_member_gets_what_anyone_gets_while_the_database_is_down(admin_user, monkeypatch):
    from django.db.backends.utils import CursorWrapper

    client = Client(raise_request_exception=False)
    client.force_login(admin_user)

    def refuse(*args, **kwargs):
        raise OperationalError("connection to server failed: Connection refused")

    monkeypatch.setattr(CursorWrapper, "execute", refuse)
    status, body, text = get(client)
    assert status == 503 and body["down"] == ["database"] and set(body) == PUBLIC | {"detail", "code"}, text
    assert json.loads(text)["checks"]["database"] == {"ok": False}
