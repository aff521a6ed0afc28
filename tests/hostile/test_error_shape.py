"""Every API error is JSON in one shape; pages show a notice, never a traceback or a blank 500."""

from __future__ import annotations

import pytest

pytestmark = pytest.mark.django_db


def assert_error(res, status: int, code: str, field: str | None = None) -> dict:
    assert res.status_code == status, res.content[:300]
    assert res["Content-Type"].startswith("application/json"), res["Content-Type"]
    body = res.json()
    assert isinstance(body["detail"], str) and body["detail"]
    assert body["code"] == code, body
    if field is not None:
        assert body["field"] == field, body
    return body


def test_it_refuses_deeply_nested_json_with_a_400(operator_api):
    res = operator_api.post("/api/robot/speech/", "[" * 100_000, content_type="application/json")
    assert "nested too deeply" in assert_error(res, 400, "parse_error")["detail"]
    res = operator_api.post("/api/robot/speech/", '{"text": ' + "[" * 40 + "]" * 40 + "}",
                            content_type="application/json")
    body = assert_error(res, 400, "invalid")
    assert "nested too deeply" in body["detail"] and body["field"].startswith("text.0.0")


@pytest.mark.parametrize("path, field", [("/api/robot/speech/", "text"), ("/api/robot/motors/", "enabled"),
                                         ("/api/robot/event/", "event"), ("/api/robot/mode/", "mode"),
                                         ("/api/robot/estop/release/", "confirm"), ("/api/navigation/goal/", "x")])
@pytest.mark.django_db(transaction=True)  # the E-STOP's entries are written by the audit writer's own connection
def test_it_refuses_a_number_too_large_to_be_finite_and_audits_the_refusal(operator_api, viewer_api, path, field):
    """1e400 parses as infinity: it once gave 500, for viewers too, because its audit row failed."""
    from robot.models import AuditEntry

    body = '{"' + field + '": 1e400}'
    assert_error(operator_api.post(path, body, content_type="application/json"), 400, "invalid", field)
    assert_error(viewer_api.post(path, body, content_type="application/json"), 403, "forbidden")
    rows = [(e.username, e.error_code, e.params.get(field)) for e in AuditEntry.objects.order_by("id")]
    assert rows == [("otto", "invalid", "inf"), ("vera", "forbidden", "inf")]


def test_it_refuses_a_body_too_large_with_a_400(operator_api, settings):
    settings.DATA_UPLOAD_MAX_MEMORY_SIZE = 1000
    res = operator_api.post("/api/robot/speech/", '{"text": "' + "a" * 2000 + '"}', content_type="application/json")
    assert "too large" in assert_error(res, 400, "too_large")["detail"]


def test_it_refuses_unparsable_and_empty_bodies_with_a_400(operator_api):
    assert_error(operator_api.post("/api/robot/speech/", "{nope", content_type="application/json"), 400, "parse_error")
    assert_error(operator_api.post("/api/robot/speech/", b"", content_type="multipart/form-data; boundary=x"),
                 400, "invalid", "text")
    assert_error(operator_api.post("/api/robot/speech/", "[1, 2]", content_type="application/json"),
                 400, "invalid", "body")
    assert_error(operator_api.post("/api/navigation/goal/", "[1, 2]", content_type="application/json"),
                 400, "invalid", "body")


def test_it_answers_unknown_api_paths_with_a_json_404(operator_api, anon_api):
    body = assert_error(operator_api.get("/api/no/such/thing/"), 404, "not_found")
    assert "/api/no/such/thing/" in body["detail"]
    assert_error(anon_api.post("/api/nothing/", {}), 404, "not_found")


def test_it_answers_a_wrong_method_with_a_json_405(operator_api):
    assert_error(operator_api.get("/api/robot/speech/"), 405, "method_not_allowed")
    assert_error(operator_api.delete("/api/robot/state/"), 405, "method_not_allowed")


def test_it_answers_throttled_commands_with_a_json_429(operator_api, settings):
    settings.COMMAND_THROTTLE_RATE = "1/min"
    operator_api.post("/api/robot/speech/", {"text": "   "}, format="json")
    res = operator_api.post("/api/robot/speech/", {"text": "   "}, format="json")
    assert_error(res, 429, "throttled")
    assert "Retry-After" in res


def test_it_rejects_unknown_fields_on_commands_and_navigation(operator_api):
    assert_error(operator_api.post("/api/robot/speech/", {"text": "hi", "volume": 11}, format="json"),
                 400, "invalid", "volume")
    res = operator_api.post("/api/navigation/goal/", {"x": 1, "y": 1, "theta": "Infinity"}, format="json")
    assert_error(res, 400, "invalid", "theta")
    res = operator_api.post("/api/navigation/initial-pose/", {"x": 1, "y": 1, "z": 0}, format="json")
    assert_error(res, 400, "invalid", "z")


@pytest.mark.parametrize("yaw", [1e308, -7, 6.3, "Infinity", "NaN", -6.2832])
def test_it_refuses_a_yaw_outside_a_turn(operator_api, yaw):
    res = operator_api.post("/api/navigation/goal/", {"x": 1, "y": 1, "yaw": yaw}, format="json")
    assert_error(res, 400, "invalid", "yaw")


@pytest.mark.parametrize("query", [
    "start=1e308&end=-1e308", "start=-1e308", "end=inf", "start=nan", "start=2020-13-45T00:00:00",
    "start=99999-01-01", "end=1e11",
])
def test_it_refuses_times_outside_the_documented_range(viewer_api, query):
    for path in ("/api/history/export/?topic=/battery_soc&", "/api/history/timeline/?",
                 "/api/history/samples/?topic=/battery_soc&field=data&"):
        res = viewer_api.get(path + query)
        assert res.status_code == 400, (path, query, res.content[:200])
        assert res.json()["code"] == "invalid"


def test_pages_show_a_notice_for_unknown_paths(client, operator):
    client.force_login(operator)
    res = client.get("/no/such/page/")
    assert res.status_code == 404
    assert "Page not found" in res.content.decode() and "Traceback" not in res.content.decode()
