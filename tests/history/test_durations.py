"""Retention in the admin reads and is typed as a duration ("30 d"), stored in seconds."""

import pytest
from django.test import Client

from history.durations import format_duration, parse_duration
from history.models import Mode, TopicPolicy

CHANGELIST = "/admin/history/topicpolicy/"


@pytest.mark.parametrize(("seconds", "text"), [(2592000.0, "30 d"), (43200.0, "12 h"), (5400.0, "90 min"),
                                               (90061.0, "90061 s"), (2.5, "2.5 s"), (None, "")])
def test_it_names_a_duration_in_its_largest_exact_unit(seconds, text):
    assert format_duration(seconds) == text


@pytest.mark.parametrize(("text", "seconds"), [("30 d", 2592000.0), ("12h", 43200.0), ("90 min", 5400.0),
                                               ("45", 45.0), ("1,5 hours", 5400.0), ("2 days", 172800.0)])
def test_it_reads_what_an_admin_types(text, seconds):
    assert parse_duration(text) == seconds


@pytest.mark.parametrize("text", ["soon", "3 weeks", "-1 d", "1 d 2 h"])
def test_it_refuses_what_is_no_duration(text):
    with pytest.raises(ValueError):
        parse_duration(text)


def test_the_policy_list_shows_and_takes_retention_as_a_duration(admin_user):
    policy = TopicPolicy.objects.create(topic="/x/retained", msg_type="std_msgs/String", mode=Mode.OFF,
                                        retention_s=2592000.0)
    admin = Client()
    admin.force_login(admin_user)

    page = admin.get(CHANGELIST).content.decode()
    assert 'value="30 d"' in page and "2592000" not in page

    form = {"form-TOTAL_FORMS": "1", "form-INITIAL_FORMS": "1", "form-0-id": str(policy.pk), "form-0-mode": "off",
            "form-0-interval_s": "", "form-0-retention_s": "12 h", "_save": "Save"}
    assert admin.post(CHANGELIST, form).status_code == 302
    policy.refresh_from_db()
    assert policy.retention_s == 43200.0

    form["form-0-retention_s"] = "a while"
    assert "A duration such as 30 d" in admin.post(CHANGELIST, form).content.decode()
