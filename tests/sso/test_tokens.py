"""API tokens when single sign-on is required: a password gives one only to a break-glass account;
a signed-in session gets its own."""

from __future__ import annotations

import pytest
from django.contrib.auth.models import Permission
from django.test import Client

from tests.conftest import PASSWORD

pytestmark = pytest.mark.django_db


@pytest.fixture(autouse=True)
def sso_required(settings):
    settings.OIDC_ISSUER, settings.OIDC_NAME, settings.SSO_REQUIRED = "https://idp.example/o", "Feide", True


def _token(username: str):
    return Client().post("/api/auth/token/", {"username": username, "password": PASSWORD},
                         content_type="application/json")


def test_an_operators_password_gets_no_token(operator):
    answer = _token(operator.username)
    assert answer.status_code == 403
    body = answer.json()
    assert body["code"] == "sso_required" and "only to a break-glass account" in body["detail"]


def test_a_break_glass_accounts_password_gets_one(operator, admin_user):
    assert _token(admin_user.username).status_code == 200  # a superuser
    operator.user_permissions.add(Permission.objects.get(codename="sign_in_with_password"))
    got = _token(operator.username)
    assert got.status_code == 200 and got.json()["token"]


def test_a_wrong_password_is_still_a_wrong_password(operator):
    answer = Client().post("/api/auth/token/", {"username": operator.username, "password": "wrong"},
                           content_type="application/json")
    assert (answer.status_code, answer.json()["code"]) == (400, "invalid")


def test_a_signed_in_session_gets_its_own_token(operator):
    browser = Client(enforce_csrf_checks=True)
    browser.force_login(operator)
    csrf = browser.get("/").cookies["csrftoken"].value
    assert browser.post("/api/auth/token/").status_code == 403  # no CSRF token: refused
    answer = browser.post("/api/auth/token/", HTTP_X_CSRFTOKEN=csrf)
    assert answer.status_code == 200, answer.content
    key = answer.json()["token"]
    assert Client().get("/api/robot/state/", HTTP_AUTHORIZATION=f"Token {key}").status_code == 200
