"""Numbers in API input are finite and within their documented physical range; unknown fields
on the navigation API are refused."""

from __future__ import annotations

import pytest

from robot.models import Location

pytestmark = pytest.mark.django_db


@pytest.mark.parametrize(("body", "field"), [
    ({"name": "dock", "x": 1e308, "y": 0}, "x"),
    ({"name": "dock", "x": 0, "y": "-Infinity"}, "y"),
    ({"name": "dock", "x": 0, "y": 0, "yaw": 7}, "yaw"),
    ({"name": "dock", "x": 0, "y": 0, "yaw": -6.2832}, "yaw"),
    ({"name": "dock", "x": 0, "y": 0, "threshold": 1e9}, "threshold"),
    ({"name": "dock", "x": 0, "y": 0, "theta": 1}, "theta"),
])
def test_it_refuses_locations_out_of_range_or_with_unknown_fields(operator_api, body, field):
    res = operator_api.post("/api/locations/", body, format="json")
    assert res.status_code == 400, res.content
    assert (res.json()["code"], res.json()["field"]) == ("invalid", field)
    assert not Location.objects.exists()


def test_it_accepts_a_location_within_range(operator_api):
    res = operator_api.post("/api/locations/", {"name": "dock", "x": -12.5, "y": 3, "yaw": 6.28}, format="json")
    assert res.status_code == 201, res.content


@pytest.mark.parametrize("topic", [{"interval_s": 1e308}, {"retention_s": 1e308}, {"max_message_bytes": 10**12}])
def test_it_refuses_recording_policies_out_of_range(admin_api, topic):
    res = admin_api.patch("/api/history/topics/", {"topics": [{"topic": "/battery_soc", **topic}]}, format="json")
    assert res.status_code == 400, res.content
    assert res.json()["field"] == f"topics.0.{next(iter(topic))}"
    assert admin_api.patch("/api/history/topics/", {"default_interval_s": 1e308}, format="json").status_code == 400
