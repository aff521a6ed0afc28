"""Admin → Alerts → Webhooks: the kinds are ticked from the kinds alerts have, and "Send a test message"
posts one to each selected webhook now and says what became of it."""

from __future__ import annotations

import json

import pytest

from robot.alerts.models import KINDS, Webhook

pytestmark = pytest.mark.django_db


def test_it_offers_the_kinds_as_choices_and_refuses_others(admin_logged_in):
    page = admin_logged_in.get("/admin/alerts/webhook/add/").content.decode()
    for kind, label in KINDS.items():
        assert f'value="{kind}"' in page and label in page
    form = {"name": "chat", "url": "http://127.0.0.1:9/hook", "enabled": "on", "min_severity": "warning"}
    refused = admin_logged_in.post("/admin/alerts/webhook/add/", {**form, "kinds": ["estop", "battery low"]})
    assert refused.status_code == 200 and "Select a valid choice" in refused.content.decode()
    assert not Webhook.objects.exists()
    kept = admin_logged_in.post("/admin/alerts/webhook/add/", {**form, "kinds": ["estop", "offline"]})
    assert kept.status_code == 302
    assert sorted(Webhook.objects.get().kinds) == ["estop", "offline"]


def test_it_sends_a_test_message_and_reports_the_outcome(admin_logged_in, http_server):
    port = http_server.server_address[1]
    good = Webhook.objects.create(name="chat", url=f"http://127.0.0.1:{port}/hook", kinds=["estop"])
    broken = Webhook.objects.create(name="gone", url=f"http://127.0.0.1:{port}/gone")

    def send_test(hook: Webhook) -> list[str]:
        answer = admin_logged_in.post("/admin/alerts/webhook/", {"action": "send_test", "_selected_action": [hook.pk]},
                                   follow=True)
        return [str(m) for m in answer.context["messages"]]

    assert send_test(good) == [f"Test message sent to chat (http://127.0.0.1:{port}/hook)."]
    body = json.loads(http_server.received[0][2])
    assert "Test message" in body["text"] and body["alert"]["kind"] == "test"
    http_server.statuses = [404]
    shown = send_test(broken)
    assert len(shown) == 1 and shown[0].startswith("Test message to gone") and "answered 404" in shown[0], shown
