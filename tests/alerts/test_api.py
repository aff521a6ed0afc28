"""The alerts API: the ones on now and their history; acknowledging (operators, admins)."""

import time
import uuid
from datetime import UTC, datetime

import pytest

from robot.alerts.models import Alert

pytestmark = pytest.mark.django_db


def an_alert(**fields) -> Alert:
    now = datetime.now(UTC)
    return Alert.objects.create(**{"key": "battery_low", "kind": "battery_low", "severity": "warning",
                                   "text": "Battery low: 15 %", "started_at": now, "updated_at": now, **fields})


def test_it_lists_the_history_newest_first(viewer_api):
    an_alert(text="old")
    an_alert(text="new", ended_at=datetime.now(UTC))
    res = viewer_api.get("/api/alerts/")
    assert res.status_code == 200
    assert [a["text"] for a in res.json()["history"]] == ["new", "old"]
    assert res.json()["on"] == []


def test_an_operator_acknowledges_once_and_the_first_acknowledgement_stands(operator_api, admin_api, operator):
    alert = an_alert()
    before = time.time()
    res = operator_api.post(f"/api/alerts/{alert.id}/ack/")
    assert res.status_code == 200, res.content
    assert res.json()["acked_by"] == operator.username and res.json()["acked_at"] >= before - 1
    again = admin_api.post(f"/api/alerts/{alert.id}/ack/")
    assert again.json()["acked_by"] == operator.username


def test_it_refuses_a_viewer_and_an_unknown_alert(viewer_api, operator_api):
    alert = an_alert()
    assert viewer_api.post(f"/api/alerts/{alert.id}/ack/").status_code == 403
    assert operator_api.post(f"/api/alerts/{uuid.uuid4()}/ack/").status_code == 404
    assert operator_api.post("/api/alerts/not-an-id/ack/").status_code == 404
    assert Alert.objects.get(id=alert.id).acked_at is None
