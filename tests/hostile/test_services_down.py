"""Redis or the database down: the API answers 503 JSON "service unavailable: …", pages an
explanatory page, /healthz 503 naming what is down; everything recovers by itself."""

from __future__ import annotations

import pytest
from channels.layers import channel_layers
from django.db import OperationalError

from tests.hostile.support import PrivateRedis

pytestmark = [pytest.mark.postgres, pytest.mark.django_db]  # the database going down


@pytest.fixture
def private_redis(settings):
    """This test's own Redis, wired in as in the scaled deployment (whatever the suite's wiring)."""
    from robot.live.state import reset_store

    server = PrivateRedis()
    server.start()
    settings.REDIS_URL = server.url
    settings.CHANNEL_LAYERS = {"default": {"BACKEND": "channels_redis.core.RedisChannelLayer",
                                           "CONFIG": {"hosts": [server.url], "prefix": "cyborg-down-test"}}}
    channel_layers.backends = {}
    reset_store()
    yield server
    server.stop()
    reset_store()
    channel_layers.backends = {}


def unavailable(res, what: str) -> None:
    assert res.status_code == 503, res.content[:300]
    body = res.json()
    assert body["code"] == "unavailable"
    assert body["detail"].startswith("service unavailable: ") and what in body["detail"], body


def test_it_reports_redis_down_and_recovers_when_it_returns(private_redis, operator_api, viewer_api, client):
    healthy = client.get("/healthz")
    assert healthy.status_code == 200, healthy.content
    assert healthy.json()["checks"]["redis"] == {"ok": True}
    assert viewer_api.get("/api/robot/state/").status_code == 200

    private_redis.stop()
    health = client.get("/healthz")
    assert health.status_code == 503
    # Redis down (and what depends on it, like the command path); the database is fine.
    assert "redis" in health.json()["down"] and health.json()["checks"]["database"]["ok"] is True
    assert "redis" in health.json()["detail"]
    unavailable(viewer_api.get("/api/robot/state/"), "Redis")
    for res in (operator_api.post("/api/robot/speech/", {"text": "hello"}, format="json"),
                operator_api.post("/api/robot/mode/", {"mode": "stop"}, format="json")):
        # Refused before anything is sent: Redis itself, or the command path that runs over it.
        assert res.status_code == 503 and res.json()["code"] in ("unavailable", "command_path"), res.content

    private_redis.start()
    assert client.get("/healthz").status_code == 200
    state = viewer_api.get("/api/robot/state/")
    assert state.status_code == 200 and state.json()["connected"] is False
    # Offline robot, reachable Redis: the command is refused for the right reason.
    assert operator_api.post("/api/robot/speech/", {"text": "hello"}, format="json").json()["code"] in ("offline",
                                                                                                         "timeout")


def take_the_database_down(monkeypatch) -> None:
    """Every query fails as it does when the database server is unreachable."""
    from django.db.backends.utils import CursorWrapper

    def refuse(*args, **kwargs):
        raise OperationalError('connection to server at "127.0.0.1", port 5432 failed: Connection refused')

    monkeypatch.setattr(CursorWrapper, "execute", refuse)
    monkeypatch.setattr(CursorWrapper, "executemany", refuse)


def test_it_reports_the_database_down_on_the_api_pages_and_healthz(operator, operator_api, monkeypatch):
    from django.test import Client
    from rest_framework.test import APIClient

    client = Client(raise_request_exception=False)
    client.force_login(operator)  # the session is stored before the database goes away
    take_the_database_down(monkeypatch)
    token_client = APIClient(raise_request_exception=False)
    unavailable(token_client.get("/api/audit/", HTTP_AUTHORIZATION="Token 0123456789abcdef"), "database")
    unavailable(operator_api.get("/api/audit/"), "database")
    health = client.get("/healthz")
    assert health.status_code == 503 and health.json()["down"] == ["database"]
    page = client.get("/activity/")
    assert page.status_code == 503
    text = page.content.decode()
    assert "Temporarily unavailable" in text and "database is not reachable" in text and "Traceback" not in text

    monkeypatch.undo()
    assert client.get("/healthz").status_code == 200
    assert client.get("/activity/").status_code == 200
