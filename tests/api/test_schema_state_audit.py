"""The OpenAPI schema and docs, the robot state for scripts, and the audit log API."""

from __future__ import annotations

import pytest

from robot.models import AuditEntry
from tests.commands.support import wait_state
from tests.helpers import wait_until

pytestmark = pytest.mark.django_db

COMMAND_PATHS = ["/api/auth/token/", "/api/robot/state/", "/api/robot/mode/", "/api/robot/event/",
                 "/api/robot/speech/", "/api/robot/emotion/", "/api/robot/emotion-system/", "/api/robot/motors/",
                 "/api/robot/playback/", "/api/robot/dome/", "/api/audit/"]


def test_it_serves_a_valid_openapi_schema(viewer_api):
    from openapi_spec_validator import validate

    res = viewer_api.get("/api/schema/?format=json")
    assert res.status_code == 200
    schema = res.json()
    validate(schema)
    assert set(COMMAND_PATHS) <= set(schema["paths"])
    mode = schema["paths"]["/api/robot/mode/"]["post"]
    assert {"200", "400", "401", "403", "409", "503", "504"} <= set(mode["responses"])
    assert {"tokenAuth", "cookieAuth"} <= set(schema["components"]["securitySchemes"])


def test_it_refuses_the_schema_to_anonymous_callers(anon_api):
    assert anon_api.get("/api/schema/").status_code == 401


def test_it_serves_offline_docs(client, viewer):
    client.force_login(viewer)
    res = client.get("/api/docs/")
    assert res.status_code == 200
    html = res.content.decode()
    assert "/static/drf_spectacular_sidecar/swagger-ui-dist/" in html
    assert "cdn" not in html.lower() and "https://" not in html
    asset = html.split('src="')[1].split('"')[0] if 'src="' in html else None
    assert asset and client.get(asset).status_code == 200


def test_it_sends_anonymous_docs_visitors_to_login(client):
    res = client.get("/api/docs/")
    assert res.status_code == 302 and "/accounts/login/" in res["Location"]


def test_it_issues_a_token_only_for_the_right_password(anon_api, operator):
    from tests.conftest import PASSWORD

    good = anon_api.post("/api/auth/token/", {"username": "otto", "password": PASSWORD}, format="json")
    assert good.status_code == 200 and len(good.json()["token"]) == 40
    bad = anon_api.post("/api/auth/token/", {"username": "otto", "password": "nope"}, format="json")
    assert bad.status_code == 400


def test_it_reports_offline_state_without_a_link(viewer_api):
    res = viewer_api.get("/api/robot/state/")
    assert res.status_code == 200
    assert res.json()["connected"] is False
    assert res.json()["values"] == {} and res.json()["mode"] is None


def test_it_reports_latest_values_ages_events_and_the_mode(viewer_api, operator_api, robot):
    wait_until(lambda: "battery_soc" in viewer_api.get("/api/robot/state/").json()["values"], what="battery value")
    body = viewer_api.get("/api/robot/state/").json()
    assert body["connected"] is True and body["link"]["connected"] is True
    battery = body["values"]["battery_soc"]
    assert 0 <= battery["value"]["data"] <= 1 and 0 <= battery["age_s"] < 10
    wait_until(lambda: viewer_api.get("/api/robot/state/").json()["available_events"].get("manual_start"),
               what="suspension's events")
    assert operator_api.post("/api/robot/mode/", {"mode": "manual"}, format="json").status_code == 200
    wait_state(robot, lambda s: s["smach_state"] == "manual", "state manual")
    mode = wait_until(lambda: (m := viewer_api.get("/api/robot/state/").json()["mode"]) and m["reached"] and m,
                      what="mode reached")
    assert (mode["mode"], mode["by"], mode["status"], mode["state"]) == ("manual", "otto", "reached", "manual")
    assert viewer_api.get("/api/robot/state/").json()["available_events"] == {"succeeded": "suspension",
                                                                               "aborted": "suspension"}


def _entry(username: str, action: str, ok: bool, source: str = "api") -> AuditEntry:
    return AuditEntry.objects.create(username=username, action=action, ok=ok, source=source,
                                     params={"x": 1}, outcome="done" if ok else "refused")


def test_it_lists_the_audit_log_newest_first_with_filters(viewer_api, anon_api):
    first = _entry("otto", "mode", True)
    second = _entry("vera", "speech", False, "page")
    third = _entry("otto", "speech", True)
    res = viewer_api.get("/api/audit/")
    assert res.status_code == 200  # viewers may read it: monitoring, not commanding
    assert [e["id"] for e in res.json()["results"]] == [third.id, second.id, first.id]
    assert res.json()["count"] == 3
    assert [e["id"] for e in viewer_api.get("/api/audit/?outcome=failed").json()["results"]] == [second.id]
    assert [e["id"] for e in viewer_api.get("/api/audit/?user=otto&action=speech").json()["results"]] == [third.id]
    assert [e["id"] for e in viewer_api.get("/api/audit/?source=page").json()["results"]] == [second.id]
    page = viewer_api.get("/api/audit/?page_size=2").json()
    assert len(page["results"]) == 2 and page["next"]
    assert anon_api.get("/api/audit/").status_code == 401
