"""The Alerts page and the choice of alerts beyond the tab (each person's own)."""

from datetime import UTC, datetime

import pytest

from robot.alerts.models import Alert, AlertChoice, PushSubscription

pytestmark = pytest.mark.django_db


def test_it_lists_the_history_with_who_acknowledged(client, viewer):
    now = datetime.now(UTC)
    Alert.objects.create(key="estop", kind="estop", severity="critical", text="E-STOP engaged by olga",
                         started_at=now, updated_at=now, ended_at=now, acked_at=now, acked_by_name="otto")
    client.force_login(viewer)
    page = client.get("/alerts/")
    assert page.status_code == 200
    assert b"E-STOP engaged by olga" in page.content and b"otto" in page.content
    assert b"E-STOP engaged by olga" not in client.get("/alerts/?kind=log").content


def test_a_person_chooses_kinds_severity_and_ways(viewer_api, viewer):
    viewer.email = "vera@example.org"
    viewer.save()
    res = viewer_api.patch("/api/me/alert-delivery/", {"kinds": ["estop", "offline", "estop"], "by_email": True,
                                                        "min_severity": "error"}, format="json")
    assert res.status_code == 200, res.content
    assert res.json()["kinds"] == ["estop", "offline"] and res.json()["push_public_key"]
    choice = AlertChoice.objects.get(user=viewer)
    assert choice.wants("estop", "critical")
    assert not choice.wants("estop", "warning") and not choice.wants("log", "error")


def test_it_refuses_unknown_kinds_fields_and_mail_without_an_address(viewer_api):
    assert viewer_api.patch("/api/me/alert-delivery/", {"kinds": ["nope"]}, format="json").status_code == 400
    assert viewer_api.patch("/api/me/alert-delivery/", {"colour": "red"}, format="json").status_code == 400
    assert viewer_api.patch("/api/me/alert-delivery/", {"min_severity": "meh"}, format="json").status_code == 400
    assert viewer_api.patch("/api/me/alert-delivery/", {"by_email": True}, format="json").status_code == 400
    assert not AlertChoice.objects.exists()


def test_a_browser_subscribes_and_unsubscribes(viewer_api, viewer):
    sub = {"endpoint": "https://push.example.org/send/abc", "keys": {"p256dh": "BNc", "auth": "tBH"}}
    assert viewer_api.post("/api/me/push-subscriptions/", sub, format="json").status_code == 204
    assert viewer_api.post("/api/me/push-subscriptions/", sub, format="json").status_code == 204  # once
    assert PushSubscription.objects.get().user == viewer
    bad = {"endpoint": "javascript:alert(1)", "keys": {"p256dh": "x", "auth": "y"}}
    assert viewer_api.post("/api/me/push-subscriptions/", bad, format="json").status_code == 400
    assert viewer_api.delete("/api/me/push-subscriptions/", {"endpoint": sub["endpoint"]},
                             format="json").status_code == 204
    assert not PushSubscription.objects.exists()
