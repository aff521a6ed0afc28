"""Who changed what is recorded, from what to what: the admin (form, list edits, bulk actions) and
the API write an audit entry for every policy and default-interval change, and none when nothing
changed."""

from __future__ import annotations

import pytest
from django.test import Client

from history.models import Mode, TopicPolicy
from robot.models import AuditEntry

# The history store: its writes, queries and rollups differ by engine.
pytestmark = [pytest.mark.postgres, pytest.mark.django_db]
MIC = "/audio/audio"


def _rows(action: str = "history.policy") -> list[tuple]:
    return [(e.username, e.source, e.params) for e in AuditEntry.objects.filter(action=action).order_by("id")]


def test_the_api_audits_each_change_from_what_to_what(admin_api):
    TopicPolicy.objects.create(topic=MIC, msg_type="audio_common_msgs/AudioData", mode=Mode.OFF)
    body = {"default_interval_s": 7, "topics": [{"topic": MIC, "mode": "every"}]}
    assert admin_api.patch("/api/history/topics/", body, format="json").status_code == 200
    [(who, source, params)] = _rows()
    assert (who, source, params["topic"]) == ("ada", "api", MIC)
    assert (params["from"]["mode"], params["to"]["mode"]) == ("off", "every")
    [(_, _, interval)] = _rows("history.default_interval")
    assert interval["to"] == 7
    admin_api.patch("/api/history/topics/", body, format="json")  # the same again: nothing changed
    assert len(_rows()) == 1 and len(_rows("history.default_interval")) == 1


def test_the_admin_audits_its_bulk_actions_and_deletions(admin_user):
    policy = TopicPolicy.objects.create(topic=MIC, msg_type="audio_common_msgs/AudioData", mode=Mode.OFF)
    admin = Client()
    admin.force_login(admin_user)
    changelist = "/admin/history/topicpolicy/"
    assert admin.post(changelist, {"action": "set_mode_every", "_selected_action": [policy.pk]}).status_code == 302
    assert admin.post(f"{changelist}{policy.pk}/delete/", {"post": "yes"}).status_code == 302
    [(who, source, turned_on), (_, _, removed)] = _rows()
    assert (who, source) == (admin_user.username, "page")
    assert (turned_on["from"]["mode"], turned_on["to"]["mode"]) == ("off", "every")
    assert removed["from"]["mode"] == "every" and removed["to"] is None
