"""The account an SSO identity signs in to, and the login form when single sign-on is required."""

from __future__ import annotations

import pytest
from django.contrib.auth.models import Permission, User
from django.test import Client

from cyborg_site.roles import Role, role_of
from dashboard.sso.people import AccountDisabled, account_for
from tests.conftest import PASSWORD

pytestmark = pytest.mark.django_db

ISSUER = "https://idp.example/o"


def test_an_identity_gets_one_account_whose_role_follows_the_provider_at_every_login():
    claims = {"sub": "8c1e", "preferred_username": "kari", "email": "kari@ntnu.no", "given_name": "Kari"}
    first = account_for(ISSUER, claims, Role.OPERATOR)
    assert (first.username, first.email, first.first_name, role_of(first)) == ("kari", "kari@ntnu.no", "Kari",
                                                                                Role.OPERATOR)
    assert not first.has_usable_password()
    again = account_for(ISSUER, claims, Role.VIEWER)  # taken out of the operators' group meanwhile
    assert again.pk == first.pk
    assert role_of(User.objects.get(pk=first.pk)) == Role.VIEWER
    admin = account_for(ISSUER, claims, Role.ADMIN)
    assert admin.is_staff and not admin.is_superuser and role_of(admin) == Role.ADMIN


def test_the_same_name_from_another_identity_gets_an_account_of_its_own(operator):
    other = account_for(ISSUER, {"sub": "77", "preferred_username": operator.username}, Role.VIEWER)
    third = account_for("https://elsewhere.example", {"sub": "77", "preferred_username": operator.username},
                        Role.VIEWER)
    assert len({operator.pk, other.pk, third.pk}) == 3
    assert other.username == f"{operator.username}-2" and third.username == f"{operator.username}-3"
    assert role_of(User.objects.get(pk=operator.pk)) == Role.OPERATOR


def test_an_account_an_admin_deactivated_stays_out():
    user = account_for(ISSUER, {"sub": "9"}, Role.OPERATOR)
    user.is_active = False
    user.save()
    with pytest.raises(AccountDisabled):
        account_for(ISSUER, {"sub": "9"}, Role.OPERATOR)


def _log_in(username: str) -> tuple[int, str]:
    answer = Client().post("/accounts/login/", {"username": username, "password": PASSWORD})
    return answer.status_code, answer.content.decode()


def test_with_sso_required_the_form_is_for_break_glass_accounts(settings, operator, admin_user):
    settings.OIDC_ISSUER, settings.OIDC_NAME = ISSUER, "Feide"
    status, page = _log_in(operator.username)
    assert status == 302
    page = Client().get("/accounts/login/").content.decode()
    assert "Sign in with Feide" in page
    settings.SSO_REQUIRED = True
    status, page = _log_in(operator.username)
    assert status == 200 and "Sign in with Feide: passwords here are for break-glass accounts only." in page
    assert _log_in(admin_user.username)[0] == 302  # a superuser is break-glass
    operator.user_permissions.add(Permission.objects.get(codename="sign_in_with_password"))
    assert _log_in(operator.username)[0] == 302
    assert _log_in("nobody")[1].count("Wrong username or password.") == 1


def test_without_a_provider_the_login_page_is_as_before(client):
    page = client.get("/accounts/login/").content.decode()
    assert "Sign in with" not in page
    assert client.get("/accounts/sso/login/").status_code == 404


def test_the_admin_shows_a_persons_identity(admin_user, operator):
    user = account_for(ISSUER, {"sub": "8c1e", "preferred_username": "kari"}, Role.OPERATOR)
    client = Client()
    client.force_login(admin_user)
    page = client.get(f"/admin/auth/user/{user.pk}/change/").content.decode()
    assert f"8c1e at {ISSUER}; the provider&#x27;s claims gave operator at the last login" in page
    assert "None: a local account" in client.get(f"/admin/auth/user/{operator.pk}/change/").content.decode()
