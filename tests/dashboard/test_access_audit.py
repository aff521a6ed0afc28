"""Changes of who may do what, and of the robot's named settings, are audited with who made them:
the admin, the API, a management command."""

from __future__ import annotations

import pytest
from axes.models import AccessAttempt
from django.contrib.auth.models import Group
from django.core.management import call_command
from django.test import Client

from cyborg_site.roles import Role
from robot.models import AuditEntry, Location
from tests.conftest import PASSWORD

pytestmark = pytest.mark.django_db(transaction=True)  # entries written when the change commits


def _fresh() -> None:
    """Forget what the fixtures' accounts wrote."""
    AuditEntry.objects.all().delete()


def _entries(action: str) -> list[AuditEntry]:
    return list(AuditEntry.objects.filter(action=action).order_by("pk"))


def _admin_client(admin_user) -> Client:
    client = Client()
    client.force_login(admin_user)
    return client


def test_a_role_given_in_the_admin_says_who_gave_it_from_what_to_what(admin_user, viewer):
    _fresh()
    client = _admin_client(admin_user)
    form = {"username": viewer.username, "is_active": "on", "groups": [Group.objects.get(name=Role.OPERATOR).pk],
            "last_login_0": "", "last_login_1": "", "date_joined_0": "2026-01-01", "date_joined_1": "10:00:00",
            "first_name": "", "last_name": "", "email": ""}
    res = client.post(f"/admin/auth/user/{viewer.pk}/change/", form)
    assert res.status_code == 302, res.content.decode()[:3000]
    [entry] = _entries("account.roles")
    assert (entry.username, entry.source) == (admin_user.username, "page")
    assert entry.params == {"username": "vera", "from": ["viewer"], "to": ["operator"]}


def test_roles_changed_from_the_groups_side_are_audited_per_person(operator, viewer):
    _fresh()
    Group.objects.get(name=Role.OPERATOR).user_set.add(viewer)
    Group.objects.get(name=Role.OPERATOR).user_set.clear()
    changes = [(e.params["username"], e.params["to"]) for e in _entries("account.roles")]
    assert ("vera", ["operator", "viewer"]) in changes
    assert ("vera", ["viewer"]) in changes and ("otto", []) in changes
    assert all(e.source == "system" and e.username == "" for e in _entries("account.roles"))


def test_account_flags_password_and_deletion(operator):
    _fresh()
    operator.is_active = False
    operator.save()
    [changed] = _entries("account.changed")
    assert changed.params["changes"] == {"is_active": {"from": True, "to": False}}
    operator.set_password("another long password")
    operator.save()
    [password] = _entries("account.password")
    assert "password" not in password.params and "pbkdf2" not in str(password.params)
    operator.delete()
    assert _entries("account.deleted")[0].params == {"username": "otto"}


def test_adduser_is_audited_as_the_system(db):
    _fresh()
    call_command("adduser", "newbie", "--role", "viewer", "--password", "a long enough password 1")
    [entry] = _entries("account.created")
    assert entry.source == "system" and entry.params["username"] == "newbie"
    assert any(e.params["to"] == ["viewer"] for e in _entries("account.roles"))


def test_tokens_made_through_the_api_and_deleted_in_the_admin(admin_user, operator):
    _fresh()
    client = Client()
    res = client.post("/api/auth/token/", {"username": "otto", "password": PASSWORD}, content_type="application/json")
    assert res.status_code == 200
    [made] = _entries("token.created")
    assert (made.username, made.source, made.params) == ("otto", "api", {"username": "otto"})
    admin = _admin_client(admin_user)
    res = admin.post(f"/admin/authtoken/tokenproxy/{operator.pk}/delete/", {"post": "yes"})
    assert res.status_code == 302
    [deleted] = _entries("token.deleted")
    assert (deleted.username, deleted.params) == ("ada", {"username": "otto"})


def test_a_lockout_cleared_by_an_admin_is_audited_and_a_login_reset_is_not(admin_user, operator):
    _fresh()
    AccessAttempt.objects.create(username="otto", ip_address="127.0.0.1", user_agent="", failures_since_start=1,
                                 get_data="", post_data="", http_accept="", path_info="/accounts/login/")
    Client().post("/accounts/login/", {"username": "otto", "password": PASSWORD})  # resets its own failures
    assert not _entries("login.lockout_cleared")
    attempt = AccessAttempt.objects.create(username="otto", ip_address="10.0.0.9", user_agent="",
                                           failures_since_start=5, get_data="", post_data="", http_accept="",
                                           path_info="/accounts/login/")
    admin = _admin_client(admin_user)
    res = admin.post("/admin/axes/accessattempt/", {"action": "delete_selected", "_selected_action": [attempt.pk],
                                                    "post": "yes"})
    assert res.status_code == 302
    [entry] = _entries("login.lockout_cleared")
    assert entry.username == "ada" and entry.params == {"username": "otto", "ip_address": "10.0.0.9"}


def test_named_settings_added_changed_and_removed(admin_api):
    _fresh()
    res = admin_api.post("/api/locations/", {"name": "dock", "x": 1.0, "y": 2.0}, format="json")
    assert res.status_code == 201, res.content
    dock = Location.objects.get(name="dock")
    dock.x = 3.0
    dock.save()
    dock.save()  # no change: no entry
    dock.delete()
    entries = _entries("setting.changed")
    assert [e.outcome for e in entries] == ["location dock added", "location dock changed", "location dock removed"]
    assert entries[0].username == "ada" and entries[0].source == "api"
    assert entries[1].params["from"]["x"] == 1.0 and entries[1].params["to"]["x"] == 3.0


def test_a_role_change_rolled_back_leaves_later_ones_audited(operator):
    from django.db import transaction

    _fresh()
    viewers, operators = Group.objects.get(name=Role.VIEWER), Group.objects.get(name=Role.OPERATOR)
    with pytest.raises(RuntimeError), transaction.atomic():
        operator.groups.set([viewers])
        raise RuntimeError("the change fails")
    assert not _entries("account.roles")
    with transaction.atomic():
        operator.groups.set([viewers, operators])
    [entry] = _entries("account.roles")
    assert entry.params == {"username": "otto", "from": ["operator"], "to": ["operator", "viewer"]}
